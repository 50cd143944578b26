// Test fixtures for the dashboard's browser test: a real fleetd on a temporary SQLite file, tokens from its
// admin bootstrap (Admin.SetCredential), a simulated fleet uploaded over gRPC, parameter sets and
// reprocessing jobs. Node packages come from web/node_modules (web/package-lock.json).
import { spawn, execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { randomBytes } from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import readline from 'node:readline';

export const env = {
  fleetd: process.env.FLEETD,
  fleetsim: process.env.FLEETSIM,
  webDir: process.env.WEB_DIR,
  protoDir: process.env.PROTO_DIR,
  world: process.env.WORLD,
  artifacts: process.env.ARTIFACTS_DIR || path.resolve('browser-artifacts'),
  valetudo: process.env.VALETUDO_DIR,
  maps: process.env.MAPS_DIR,
};
for (const [key, value] of Object.entries(env)) {
  if (!value) throw new Error(`environment: ${key} is not set (ctest sets FLEETD, FLEETSIM, WEB_DIR, PROTO_DIR, WORLD)`);
}

export const webRequire = createRequire(path.join(env.webDir, 'package.json'));
const grpc = webRequire('@grpc/grpc-js');
const protoLoader = webRequire('@grpc/proto-loader');
const protobuf = webRequire('protobufjs');

const loaderOptions = { keepCase: true, longs: String, enums: String, defaults: true, oneofs: true, includeDirs: [env.protoDir] };
const definition = protoLoader.loadSync(['fleet/v1/service.proto'], loaderOptions);
const fleet = grpc.loadPackageDefinition(definition).fleet.v1;

const root = new protobuf.Root();
root.resolvePath = (_origin, target) => (path.isAbsolute(target) ? target : path.join(env.protoDir, target));
root.loadSync('fleet/v1/service.proto', { keepCase: true });
const RunFile = root.lookupType('fleet.v1.RunFile');

/// Starts fleetd (with `extra` flags); resolves with {grpc, http, stop(), log} once it printed its addresses.
export async function startFleetd(dir, extra = []) {
  const adminToken = `admin:browser-test.${randomBytes(24).toString('hex')}`;
  const log = fs.createWriteStream(path.join(dir, 'fleetd.log'));
  const child = spawn(env.fleetd, ['--db', `sqlite:${path.join(dir, 'fleet.db')}`, '--listen', '127.0.0.1:0',
    '--http', '127.0.0.1:0', '--workers', '2', '--log-format', 'text', '--rate-limit', '0', ...extra], {
    env: { ...process.env, FLEETD_BOOTSTRAP_ADMIN_TOKEN: adminToken, FLEETD_WEB_DIR: env.webDir },
    stdio: ['ignore', 'pipe', 'pipe'],
  });
  child.stderr.pipe(log);
  const exited = new Promise((resolve) => child.on('exit', (code, signal) => resolve({ code, signal })));
  const first = await new Promise((resolve, reject) => {
    const lines = readline.createInterface({ input: child.stdout });
    lines.once('line', (line) => resolve(line));
    child.once('exit', (code) => reject(new Error(`fleetd exited (${code}) before printing its addresses; see ${dir}/fleetd.log`)));
  });
  const addresses = JSON.parse(first);
  return {
    grpc: addresses.grpc,
    http: `http://${addresses.http}`,
    adminToken,
    async stop() {
      child.kill('SIGTERM');
      const timer = setTimeout(() => child.kill('SIGKILL'), 15000);
      const result = await exited;
      clearTimeout(timer);
      return result;
    },
  };
}

function metadata(token) {
  const m = new grpc.Metadata();
  m.set('authorization', `Bearer ${token}`);
  return m;
}

function unary(client, method, request, token) {
  return new Promise((resolve, reject) => {
    client[method](request, metadata(token), { deadline: Date.now() + 60000 }, (error, response) =>
      (error ? reject(new Error(`${method}: ${error.code} ${error.details}`)) : resolve(response)));
  });
}

export function clients(address) {
  const credentials = grpc.credentials.createInsecure();
  return {
    admin: new fleet.Admin(address, credentials),
    ingest: new fleet.Ingest(address, credentials),
    reprocessing: new fleet.Reprocessing(address, credentials),
    close() { for (const c of [this.admin, this.ingest, this.reprocessing]) c.close(); },
  };
}

/// A token for `principal` ("engineer:alice", "robot:r1"), issued with the admin token.
export async function issueToken(c, adminToken, principal) {
  const response = await unary(c.admin, 'SetCredential', { principal }, adminToken);
  return response.token;
}

export async function putParameterSet(c, token, set) {
  return unary(c.reprocessing, 'PutParameterSet', { parameter_set: set }, token);
}

export async function startReprocessing(c, token, parameterSet) {
  return unary(c.reprocessing, 'StartJob', { parameter_set: parameterSet, filter: {} }, token);
}

/// Uploads one fleet.v1.RunFile (as fleetsim --out writes it) like a robot: header, event chunks, the
/// parent snapshot when the run has one, the child snapshot last.
export function uploadRunFile(c, token, file) {
  const run = RunFile.toObject(RunFile.decode(fs.readFileSync(file)), { longs: String, enums: String, bytes: Buffer });
  return new Promise((resolve, reject) => {
    const call = c.ingest.UploadRun(metadata(token), { deadline: Date.now() + 120000 }, (error, response) =>
      (error ? reject(new Error(`UploadRun ${path.basename(file)}: ${error.code} ${error.details}`)) : resolve(response)));
    call.write({ header: run.header });
    const events = run.events || [];
    for (let i = 0; i < events.length; i += 2000) call.write({ events: { events: events.slice(i, i + 2000) } });
    if (run.parent_snapshot && (run.parent_snapshot.nodes || []).length > 0) call.write({ parent_snapshot: run.parent_snapshot });
    call.write({ child_snapshot: run.child_snapshot || { format_version: 1 } });
    call.end();
  });
}

/// Simulates `robots` × `runs` and uploads them: with `fleetsim --upload` when this fleetsim has it,
/// otherwise with `fleetsim --out` and uploads from here (robot by robot, runs in order).
export async function simulateAndUpload(c, server, token, dir, { robots, runs, minutes, seed }) {
  const help = execFileSync(env.fleetsim, ['--help'], { encoding: 'utf8' });
  const common = ['--world', env.world, '--robots', String(robots), '--runs', String(runs), '--minutes', String(minutes),
    '--seed', String(seed), '--threads', '2'];
  if (help.includes('--upload')) {
    // The token through the environment: never on a command line (other users can read those).
    execFileSync(env.fleetsim, [...common, '--upload', server.grpc],
      { stdio: ['ignore', 'ignore', 'inherit'], env: { ...process.env, FLEET_TOKEN: token } });
    return robots * runs;
  }
  const out = path.join(dir, 'runs');
  execFileSync(env.fleetsim, [...common, '--out', out], { stdio: ['ignore', 'ignore', 'ignore'] });
  let uploaded = 0;
  for (const robot of fs.readdirSync(out).sort()) {
    for (const file of fs.readdirSync(path.join(out, robot)).sort()) {
      await uploadRunFile(c, token, path.join(out, robot, file));
      ++uploaded;
    }
  }
  return uploaded;
}

/// GET with the admin token: fleetd serves no data without one.
export async function getJson(server, apiPath) {
  const response = await fetch(`${server.http}${apiPath}`, { headers: { Authorization: `Bearer ${server.adminToken}` } });
  const body = await response.json();
  if (!response.ok) throw new Error(`${apiPath}: HTTP ${response.status} ${body.error}`);
  return body;
}

/// Polls until `predicate(value)` holds for `await probe()`, or throws after `timeoutMs`.
export async function waitFor(probe, predicate, timeoutMs, what) {
  const deadline = Date.now() + timeoutMs;
  let last;
  while (Date.now() < deadline) {
    last = await probe();
    if (predicate(last)) return last;
    await new Promise((resolve) => setTimeout(resolve, 250));
  }
  throw new Error(`timed out waiting for ${what}; last: ${JSON.stringify(last).slice(0, 400)}`);
}

/// Runs `fleetsim --lifelong` (the regimes given, a small size) and returns the results file it wrote.
export function simulateLifelong(dir, { robots, runs, minutes, seed, regimes }) {
  const results = path.join(dir, 'lifelong.json');
  execFileSync(env.fleetsim, ['--lifelong', '--world', env.world, '--robots', String(robots), '--runs', String(runs),
    '--minutes', String(minutes), '--seed', String(seed), '--regimes', regimes, '--results', results,
    '--fleetd', env.fleetd, '--work-dir', path.join(dir, 'lifelong')], { stdio: ['ignore', 'ignore', 'ignore'] });
  return results;
}
