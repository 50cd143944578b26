// Fetch helpers: JSON from /api, errors as exceptions carrying the server's {"error": ...} message.
export class ApiError extends Error {
  /// `code`: fleetd's status name ("ABORTED", "FAILED_PRECONDITION", …) when the error body carries one.
  constructor(status, message, code = '') { super(message); this.status = status; this.code = code; }
}

export async function getJson(path, params = {}) {
  const query = new URLSearchParams();
  for (const [key, value] of Object.entries(params)) {
    if (value !== undefined && value !== null && value !== '') query.set(key, value);
  }
  const url = query.toString() ? `${path}?${query}` : path;
  let response;
  try {
    response = await fetch(url, { headers: { Accept: 'application/json' } });
  } catch (e) {
    throw new ApiError(0, `fleetd is unreachable (${e.message})`);
  }
  return parse(response);
}

export async function postJson(path, body, token) {
  const headers = { 'Content-Type': 'application/json' };
  if (token) headers.Authorization = `Bearer ${token}`;
  let response;
  try {
    response = await fetch(path, { method: 'POST', headers, body: JSON.stringify(body) });
  } catch (e) {
    throw new ApiError(0, `fleetd is unreachable (${e.message})`);
  }
  return parse(response);
}

async function parse(response) {
  const text = await response.text();
  let body = null;
  try { body = text ? JSON.parse(text) : null; } catch { body = null; }
  if (!response.ok) throw new ApiError(response.status, (body && body.error) || text || response.statusText, (body && body.code) || '');
  return body;
}

// ---- Engineer token for labelling and map repairs: asked for once, kept for the browser session only. ----
const TOKEN_KEY = 'fleetd.token';
export function getToken() { return sessionStorage.getItem(TOKEN_KEY) || ''; }
export function setToken(token) {
  if (token) sessionStorage.setItem(TOKEN_KEY, token); else sessionStorage.removeItem(TOKEN_KEY);
  updateTokenStatus();
}
export function askToken(reason) {
  const token = window.prompt(`${reason}\nPaste an engineer token (engineer:<name>.<secret>); it is kept for this tab only.`);
  if (token) setToken(token.trim());
  return getToken();
}
export function updateTokenStatus() {
  const element = document.getElementById('token-status');
  if (!element) return;
  const token = getToken();
  element.textContent = token ? `signed in as ${token.split('.')[0]}` : 'read-only (labelling and repairs ask for a token)';
}

/// POSTs with the engineer token, asking for it once when there is none; a token the server refuses is
/// forgotten, so the next attempt asks again.
export async function postAsEngineer(path, body, why) {
  const token = getToken() || askToken(why);
  if (!token) throw new ApiError(401, 'no engineer token given');
  try {
    return await postJson(path, body, token);
  } catch (error) {
    if (error instanceof ApiError && (error.status === 401 || error.status === 403)) setToken('');
    throw error;
  }
}
