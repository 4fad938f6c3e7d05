// The real drivegw for the browser tests: its embedded demo (simulated LinMot drives on
// loopback UDP, docs/config.md "Demo drives") on free HTTP/gRPC ports with a temp data dir,
// tokens made with `drivegw token create` on the test's database (decision 015).
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';

export function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.once('error', reject);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Polls `fn` until it returns a truthy value or `ms` pass (then throws naming `what`).
export async function waitFor(what, fn, ms = 10000) {
  const end = Date.now() + ms;
  let last;
  while (Date.now() < end) {
    try {
      const v = await fn();
      if (v) return v;
    } catch (e) {
      last = e;
    }
    await sleep(100);
  }
  throw new Error(`timed out waiting for ${what}${last ? `: ${last.message}` : ''}`);
}

export class Gateway {
  constructor(binary, dir, { auth = false } = {}) {
    this.binary = binary;
    this.dir = dir;
    this.auth = auth;
  }

  async start() {
    fs.mkdirSync(this.dir, { recursive: true });
    this.httpPort = await freePort();
    this.grpcPort = await freePort();
    this.config = path.join(this.dir, 'gw.yaml');
    fs.writeFileSync(
      this.config,
      [
        `listen: {grpc: 127.0.0.1:${this.grpcPort}, http: 127.0.0.1:${this.httpPort}}`,
        `data_dir: ${path.join(this.dir, 'data')}`,
        `auth: {enabled: ${this.auth}}`,
        'shutdown_timeout_s: 5',
        '',
      ].join('\n'),
    );
    if (this.auth) this.adminToken = this.token('admin');
    const log = fs.openSync(path.join(this.dir, 'drivegw.log'), 'w');
    this.proc = spawn(this.binary, ['--config', this.config], { stdio: ['ignore', log, log] });
    this.exited = new Promise((r) => this.proc.once('exit', r));
    this.base = `http://127.0.0.1:${this.httpPort}`;
    // The demo's simulators bind fixed loopback ports (docs/config.md "Demo drives"): another
    // demo on this machine (scripts/run-demo.sh) keeps its drives OFFLINE here; the log says so.
    try {
      await waitFor('the gateway to answer /v1/drives with every demo drive online', async () => {
        if (this.proc.exitCode !== null) throw new Error(`drivegw exited with ${this.proc.exitCode}`);
        const r = await this.rest('GET', '/v1/drives');
        return r.status === 200 && r.body.drives?.length >= 2 && r.body.drives.every((d) => d.status?.state && d.status.state !== 'OFFLINE');
      }, 20000);
    } catch (e) {
      const tail = fs.readFileSync(path.join(this.dir, 'drivegw.log'), 'utf8').split('\n').slice(-15).join('\n');
      throw new Error(`${e.message}\n--- ${this.dir}/drivegw.log (end) ---\n${tail}`);
    }
    return this;
  }

  // `drivegw token create` prints the token once on stdout.
  token(role) {
    return execFileSync(this.binary, ['token', 'create', '--name', `web-${role}-${Date.now()}`, '--role', role, '--config', this.config], {
      stdio: ['ignore', 'pipe', 'pipe'],
    })
      .toString()
      .trim()
      .split('\n')
      .pop()
      .trim();
  }

  async rest(method, p, body, token = this.adminToken) {
    const headers = { 'Content-Type': 'application/json' };
    if (token) headers.Authorization = `Bearer ${token}`;
    const r = await fetch(this.base + p, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    const text = await r.text();
    let json = null;
    try {
      json = JSON.parse(text);
    } catch {
      json = text;
    }
    return { status: r.status, body: json, headers: r.headers };
  }

  async stop() {
    if (!this.proc || this.proc.exitCode !== null) return;
    this.proc.kill('SIGTERM');
    const t = setTimeout(() => this.proc.kill('SIGKILL'), 8000);
    await this.exited;
    clearTimeout(t);
  }
}

// Where the browser loads the app: the gateway itself (GET / -> the embedded index.html, issue 8,
// decision 505). A gateway that does not serve the dashboard fails the test.
export async function appOrigin(gw) {
  const r = await fetch(`${gw.base}/`).catch((e) => ({ ok: false, status: String(e) }));
  const html = r.ok ? await r.text() : '';
  if (!html.includes('data-testid="nav-fleet"')) {
    throw new Error(`GET ${gw.base}/ did not return the dashboard (status ${r.status}): build web/ with scripts/build-web.sh (scripts/build.sh does)`);
  }
  return { origin: gw.base, served: 'gateway', close: async () => {} };
}
