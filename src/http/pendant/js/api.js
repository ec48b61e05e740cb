// The REST client of the page: same-origin calls to /v1/…, the bearer token (asked for once,
// kept for the browser session, forgotten on sign-out), and the service's error shape
// (`{error: {code, message}}`) turned into ApiError: a 403's message says which role it needs.

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
let tokenChanged = () => {}; // called after a new token is kept, set by the page

export function onTokenNeeded(fn) {
  askToken = fn;
}

/** `fn()` runs after the page is given another token (who is calling may have changed). */
export function onTokenChanged(fn) {
  tokenChanged = fn;
}

function keep(given) {
  token = given;
  sessionStorage.setItem(TOKEN_KEY, token);
  tokenChanged();
}

/** Whether the page holds a token (it may still be refused). */
export function hasToken() {
  return Boolean(token);
}

/** Forgets the token (sign out): the next guarded call asks for one. */
export function forget() {
  token = null;
  sessionStorage.removeItem(TOKEN_KEY);
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
  keep(await askToken());
}

/** One call; a 401 asks for the token and tries again with it. */
export async function call(method, path, body) {
  for (;;) {
    try {
      return await send(method, path, body);
    } catch (e) {
      if (!(e instanceof ApiError) || e.status !== 401 || !askToken) throw e;
      keep(await askToken());
    }
  }
}

export const get = (path) => call('GET', path);
export const post = (path, body = {}) => call('POST', path, body);
export const patch = (path, body) => call('PATCH', path, body);
export const del = (path) => call('DELETE', path);
