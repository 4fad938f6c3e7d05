// The demo gateway with auth on: login with tokens of the viewer and operator roles (made with
// `drivegw token create`); the viewer sees no command buttons, the operator's work (decision 015).
import path from 'node:path';
import { Gateway, appOrigin } from './gateway.mjs';
import { tid, text, shot, expect, login } from './page_util.mjs';

let env = null;

async function setup(ctx) {
  if (env) return env;
  const gw = await new Gateway(ctx.gateway, path.join(ctx.out, 'auth'), { auth: true }).start();
  const app = await appOrigin(gw);
  env = { gw, app, viewer: gw.token('viewer'), operator: gw.token('operator') };
  // A stored set, so the parameter-sets page has buttons to gate (apply is the engineer's).
  const c = await gw.rest('POST', '/v1/parameterSets', { name: 'roles', family: 'linmot', parameters: [] });
  if (c.status !== 200) throw new Error(`create set: ${c.status} ${JSON.stringify(c.body)}`);
  return env;
}

export async function teardown() {
  if (!env) return;
  await env.app.close();
  await env.gw.stop();
  env = null;
}

// Buttons a role may not use are hidden or disabled (both count).
const usable = (loc) => loc.evaluate((b) => !b.hidden && !b.disabled && b.offsetParent !== null);

// The parameter-sets page: diff for every role, dry run and apply for engineers (decision 015).
async function gateCheck(page, app, want) {
  await page.goto(`${app.origin}/#/parameter-sets`);
  await tid(page, 'pset-row-roles').click();
  await tid(page, 'btn-diff').waitFor({ timeout: 5000 });
  for (const [id, key] of [['btn-diff', 'diff'], ['btn-dry-run', 'dryRun'], ['btn-apply', 'apply']]) {
    expect((await usable(tid(page, id))) === want[key], `${id} usable: expected ${want[key]}`);
  }
}

export const tests = [
  [
    'auth: without a token the app asks for one',
    async (ctx) => {
      const { app } = await setup(ctx);
      const page = await ctx.browser.newPage();
      await page.goto(`${app.origin}/#/fleet`);
      await tid(page, 'login-token').waitFor({ timeout: 10000 });
      expect(page.url().endsWith('#/login'), `redirected to login: ${page.url()}`);
      await tid(page, 'login-token').fill('dgw_not_a_token');
      await tid(page, 'login-submit').click();
      await text(page.locator('form.login p.error'), /not accepted|401/, 'refusal of a bad token');
      await page.close();
    },
  ],
  [
    'auth: a viewer sees the fleet but no usable command buttons',
    async (ctx) => {
      const { gw, app, viewer } = await setup(ctx);
      const who = await gw.rest('GET', '/v1/whoami', undefined, viewer);
      expect(who.status === 200 && who.body.role === 'viewer', `GET /v1/whoami as viewer: ${who.status} ${JSON.stringify(who.body)}`);
      const page = await ctx.browser.newPage();
      await login(page, app.origin, viewer, 'viewer');
      await text(tid(page, 'drive-card-x1').locator('[data-testid=state]'), /\w/, 'viewer sees card x1');
      await page.goto(`${app.origin}/#/drives/x1`);
      await text(tid(page, 'drive-state'), /\w/, 'viewer sees x1 state');
      for (const b of ['btn-enable', 'btn-disable', 'btn-home', 'btn-ack', 'btn-move-absolute', 'btn-stop']) {
        expect(!(await usable(tid(page, b))), `${b} usable for a viewer`);
      }
      const writes = await page.locator('[data-testid^=param-row-] button', { hasText: 'Write' }).count();
      expect(writes === 0, `${writes} parameter Write buttons shown to a viewer`);
      await gateCheck(page, app, { diff: true, dryRun: false, apply: false });
      await page.goto(`${app.origin}/#/curves`);
      await text(tid(page, 'curve-plot').locator('xpath=..'), /Curves/, 'curves page');
      expect(!(await usable(tid(page, 'btn-run-curve'))), 'btn-run-curve usable for a viewer');
      await shot(page, ctx.out, 'viewer');
      await page.close();
    },
  ],
  [
    'auth: an operator enables x1 and moves it from the UI',
    async (ctx) => {
      const { app, operator } = await setup(ctx);
      const page = await ctx.browser.newPage();
      await login(page, app.origin, operator, 'operator');
      await page.goto(`${app.origin}/#/drives/x1`);
      await text(tid(page, 'drive-state'), /\w/, 'x1 state');
      for (const b of ['btn-enable', 'btn-move-absolute', 'btn-stop', 'btn-ack']) expect(await usable(tid(page, b)), `${b} not usable for an operator`);
      await tid(page, 'btn-enable').click();
      await text(tid(page, 'drive-state'), /ENABLED/, 'x1 ENABLED by the operator');
      await tid(page, 'move-position').fill('30');
      await tid(page, 'btn-move-absolute').click();
      await text(tid(page, 'drive-position'), (t) => Math.abs(Number.parseFloat(t) - 30) < 0.05, 'x1 at 30 mm', 15000);
      await text(tid(page, 'command-state'), /DONE/, 'move DONE');
      await shot(page, ctx.out, 'operator');
      await gateCheck(page, app, { diff: true, dryRun: false, apply: false });
      await page.close();
    },
  ],
];
