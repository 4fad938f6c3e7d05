// Browser tests of the dashboard (issue 8) in Debian's Chromium, driven by playwright-core:
//   node tests/web/run.mjs --gateway build/server/drivegw [--out DIR] [--dist web/dist]
// Each scenario starts the real drivegw demo (gateway.mjs). Asserts on DOM content; screenshots
// go to --out. Exit 0 pass, 1 fail, 77 skipped (no /usr/bin/chromium and DGW_REQUIRE_BROWSER unset).
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';
import * as open from './open_gateway.mjs';
import * as auth from './auth_roles.mjs';
import { Skip } from './page_util.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '../..');
const CHROMIUM = '/usr/bin/chromium';

const args = Object.fromEntries(
  process.argv.slice(2).reduce((acc, a, i, all) => (a.startsWith('--') ? [...acc, [a.slice(2), all[i + 1]]] : acc), []),
);
const gateway = args.gateway && path.resolve(args.gateway);
const out = path.resolve(args.out || path.join(repo, 'build/tests/web/out'));
const dist = path.resolve(args.dist || path.join(repo, 'web/dist'));
const only = args.only || '';

if (!gateway || !fs.existsSync(gateway)) {
  console.error(`usage: node tests/web/run.mjs --gateway PATH_TO_DRIVEGW (got '${args.gateway || ''}')`);
  process.exit(1);
}
if (!fs.existsSync(CHROMIUM)) {
  if (process.env.DGW_REQUIRE_BROWSER) {
    console.error(`FAIL: ${CHROMIUM} missing and DGW_REQUIRE_BROWSER is set (scripts/install-deps.sh installs chromium)`);
    process.exit(1);
  }
  console.log(`SKIP: ${CHROMIUM} missing (apt-get install chromium, or scripts/install-deps.sh); set DGW_REQUIRE_BROWSER=1 to fail instead`);
  process.exit(77);
}

let chromium;
try {
  ({ chromium } = createRequire(path.join(repo, 'web/package.json'))('playwright-core'));
} catch {
  console.error('FAIL: playwright-core missing: run `npm ci` in web/ (scripts/build-web.sh does)');
  process.exit(1);
}

fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });
const browser = await chromium.launch({
  executablePath: CHROMIUM,
  args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync'],
});

const ctx = { gateway, out, dist, browser };
let failed = 0;
const t0 = Date.now();
for (const suite of [open, auth]) {
  for (const [name, fn] of suite.tests) {
    if (only && !name.includes(only)) continue;
    const start = Date.now();
    try {
      await fn(ctx);
      console.log(`PASS ${name} (${((Date.now() - start) / 1000).toFixed(1)} s)`);
    } catch (e) {
      if (e instanceof Skip) {
        console.log(`SKIP ${name}: ${e.message}`);
        continue;
      }
      failed++;
      console.log(`FAIL ${name}: ${e.stack || e}`);
    }
  }
  await suite.teardown?.(ctx);
}
await browser.close();
console.log(`${failed ? 'FAILED' : 'OK'}: ${failed} failed, ${((Date.now() - t0) / 1000).toFixed(1)} s, screenshots in ${out}`);
process.exit(failed ? 1 : 0);
