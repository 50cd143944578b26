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
    response = await fetch(url, { headers: authHeaders({ Accept: 'application/json' }) });
  } catch (e) {
    throw new ApiError(0, `fleetd is unreachable (${e.message})`);
  }
  return parse(response);
}

/// POSTs `body` as JSON, or a FormData as multipart/form-data (the browser writes its boundary).
export async function postJson(path, body, token) {
  const form = body instanceof FormData;
  const headers = form ? {} : { 'Content-Type': 'application/json' };
  if (token) headers.Authorization = `Bearer ${token}`;
  let response;
  try {
    response = await fetch(path, { method: 'POST', headers, body: form ? body : JSON.stringify(body) });
  } catch (e) {
    throw new ApiError(0, `fleetd is unreachable (${e.message})`);
  }
  return parse(response);
}

/// Every request carries the session's token: fleetd serves no data without one (docs/formats/service.md).
export function authHeaders(headers = {}) {
  const token = getToken();
  return token ? { ...headers, Authorization: `Bearer ${token}` } : headers;
}

/// GETs `path` with the token as a Blob (pictures and downloads, which <img src> and <a href> cannot sign).
export async function getBlob(path) {
  let response;
  try {
    response = await fetch(path, { headers: authHeaders() });
  } catch (e) {
    throw new ApiError(0, `fleetd is unreachable (${e.message})`);
  }
  if (!response.ok) return parse(response);
  return response.blob();
}

/// Shows `img` from an authenticated GET; a failure fires the image's 'error' event like a broken src.
export function loadImage(img, path) {
  getBlob(path).then((blob) => { img.src = URL.createObjectURL(blob); },
    () => img.dispatchEvent(new Event('error')));
  return img;
}

/// A link that downloads `path` with the token (as <a download>, but signed).
export function downloadLink(link, path, filename) {
  link.addEventListener('click', async (event) => {
    event.preventDefault();
    const url = URL.createObjectURL(await getBlob(path));
    const anchor = document.createElement('a');
    anchor.href = url; anchor.download = filename;
    document.body.append(anchor); anchor.click(); anchor.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  });
  return link;
}

// ---- Sign-in: a 401 forgets the token and shows the form; signing in re-renders the page. ----
let signInHandler = () => {};
export function onSignInNeeded(handler) { signInHandler = handler; }

async function parse(response) {
  if (response.status === 401) {
    setToken('');
    signInHandler();
  }
  const text = await response.text();
  let body = null;
  try { body = text ? JSON.parse(text) : null; } catch { body = null; }
  if (!response.ok) throw new ApiError(response.status, (body && body.error) || text || response.statusText, (body && body.code) || '');
  return body;
}

// ---- The session's token (any role; labelling and map repairs need an engineer's): kept for this tab only. ----
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
  element.textContent = token ? `signed in as ${token.split('.')[0]}` : 'not signed in';
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
