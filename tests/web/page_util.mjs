// Small helpers over a playwright Page: wait for DOM text, screenshots, login.
import path from 'node:path';
import { waitFor } from './gateway.mjs';

export const tid = (page, id) => page.locator(`[data-testid="${id}"]`);

// Waits until the element's text satisfies `pred` (a RegExp or a function); returns the text.
export async function text(loc, pred, what, ms = 10000) {
  const ok = typeof pred === 'function' ? pred : (t) => pred.test(t);
  let last = '';
  try {
    const found = await waitFor(what, async () => {
      last = (await loc.first().textContent({ timeout: 1000 })) ?? '';
      return ok(last) ? { last } : null;
    }, ms);
    return found.last;
  } catch (e) {
    throw new Error(`${e.message} (last text: '${last}')`);
  }
}

export async function shot(page, out, name) {
  await page.screenshot({ path: path.join(out, `${name}.png`), fullPage: true });
}

export function expect(cond, message) {
  if (!cond) throw new Error(message);
}

// Logs in through the login page with `token`; waits for whoami to name the role.
export async function login(page, origin, token, role) {
  await page.goto(`${origin}/#/login`);
  await tid(page, 'login-token').fill(token);
  await tid(page, 'login-submit').click();
  await text(tid(page, 'whoami'), new RegExp(`\\(${role}\\)`), `whoami to show role ${role}`);
}

// Thrown by a test whose precondition the gateway under test lacks; run.mjs reports SKIP with it.
export class Skip extends Error {}
