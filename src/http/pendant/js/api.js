// The REST client of the page: same-origin calls to /v1/…, the bearer token (asked for once,
// kept for the browser session, replaced by one the dialog checked), and the service's error shape
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

async function send(method, path, body, secret = token) {
  const headers = { Accept: 'application/json' };
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  if (secret) headers.Authorization = `Bearer ${secret}`;
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

/**
 * Who `secret` is (`GET /v1/whoami` with it, not with the token kept): the dialog checks a
 * token before keeping it. Refused: the service's ApiError (a 401 says why).
 */
export function whoIs(secret) {
  return send('GET', '/v1/whoami', undefined, secret);
}

/** Keeps a token the dialog checked; the page then starts again as its caller. */
export function use(secret) {
  keep(secret);
}

/**
 * Asks for the token now (the service said it wants one) and keeps it. The dialog may be
 * closed without one: then this throws, and the page stays signed out with its Sign in.
 */
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
