// The REST client of the page: same-origin calls to /v1/…, the bearer token (asked for once,
// kept for the browser session), and the service's error shape turned into ApiError.

const TOKEN_KEY = 'nextpose-token';

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

let token = sessionStorage.getItem(TOKEN_KEY);
let askToken = null; // () => Promise<string>, set by the page

export function onTokenNeeded(fn) {
  askToken = fn;
}

async function send(method, path, body) {
  const headers = { Accept: 'application/json' };
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  if (token) headers.Authorization = `Bearer ${token}`;
  const response = await fetch(path, {
    method,
    headers,
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  if (response.status === 204) return null;
  const text = await response.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    throw new ApiError(response.status, 'bad_response', `${method} ${path}: not JSON`);
  }
  if (!response.ok) {
    const e = data && data.error ? data.error : { code: 'error', message: response.statusText };
    throw new ApiError(response.status, e.code, e.message);
  }
  return data;
}

/** Asks for the token now (the service said it wants one) and keeps it. */
export async function ask() {
  token = await askToken();
  sessionStorage.setItem(TOKEN_KEY, token);
}

/** One call; a 401 asks for the token and tries again with it. */
export async function call(method, path, body) {
  for (;;) {
    try {
      return await send(method, path, body);
    } catch (e) {
      if (!(e instanceof ApiError) || e.status !== 401 || !askToken) throw e;
      token = await askToken();
      sessionStorage.setItem(TOKEN_KEY, token);
    }
  }
}

export const get = (path) => call('GET', path);
export const post = (path, body = {}) => call('POST', path, body);
export const patch = (path, body) => call('PATCH', path, body);
export const del = (path) => call('DELETE', path);
