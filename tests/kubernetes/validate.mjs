// Validates deploy/kubernetes offline (issue 9): every document against the Kubernetes schema of
// kubernetes-models, then our rules (rules.mjs). Exits 1 naming file, document index and field.
//   node validate.mjs [--dir DIR]          check DIR (default: ../../deploy/kubernetes)
//   node validate.mjs --self-test [--dir]  DIR must pass, and each fixtures/bad-*.yaml must make
//                                          it fail with a finding containing its "# expect:" text.
// A fixture either "# replaces: FILE" with its own text, or "# patches: FILE" with lines
// "# set: PATH = JSON" (JSON `undefined` deletes) applied to FILE's first document.
import { readdirSync, readFileSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { parse, stringify } from "yaml";
import { loadSet } from "./load.mjs";
import { checkRules } from "./rules.mjs";

const here = dirname(fileURLToPath(import.meta.url));

function readSet(dir) {
  const files = new Map();
  for (const name of readdirSync(dir).sort()) {
    if (/\.ya?ml$/.test(name)) files.set(name, readFileSync(join(dir, name), "utf8"));
  }
  return files;
}

async function validate(files) {
  const loaded = await loadSet(files);
  return [...loaded.findings, ...checkRules(files, loaded)];
}

function header(text, key) {
  const m = text.match(new RegExp(`^# ${key}: (.+)$`, "m"));
  return m ? m[1].trim() : null;
}

// "spec.containers[0].name" -> ["spec", "containers", 0, "name"]
function pathOf(path) {
  return path.split(/\.|(?=\[)/).map((p) => (p.startsWith("[") ? Number(p.slice(1, -1)) : p));
}

// Applies the fixture's "# set: PATH = JSON" lines to the first document of `text`.
function patched(text, fixture) {
  const obj = parse(text);
  for (const [, path, json] of fixture.matchAll(/^# set: (\S+) = (.+)$/gm)) {
    const keys = pathOf(path);
    let node = obj;
    for (const k of keys.slice(0, -1)) node = node[k] ??= {};
    if (json.trim() === "undefined") delete node[keys.at(-1)];
    else node[keys.at(-1)] = JSON.parse(json);
  }
  return stringify(obj);
}

async function selfTest(dir) {
  let passed = 0;
  let failed = 0;
  const good = readSet(dir);
  const base = await validate(good);
  if (base.length === 0) {
    passed++;
    console.log(`PASS ${dir} is valid`);
  } else {
    failed++;
    console.log(`FAIL ${dir} should be valid:\n  ${base.join("\n  ")}`);
  }
  const fixtures = join(here, "fixtures");
  const bad = readdirSync(fixtures).filter((f) => /^bad-.*\.yaml$/.test(f)).sort();
  for (const name of bad) {
    const text = readFileSync(join(fixtures, name), "utf8");
    const replaces = header(text, "replaces");
    const patches = header(text, "patches");
    const expect = header(text, "expect");
    if (!(replaces || good.has(patches)) || !expect) {
      failed++;
      console.log(`FAIL ${name}: needs "# replaces: FILE" or "# patches: FILE", and "# expect: TEXT"`);
      continue;
    }
    const files = new Map(good);
    if (replaces) files.set(replaces, text);
    else files.set(patches, patched(good.get(patches), text));
    const findings = await validate(files);
    if (findings.some((f) => f.includes(expect))) {
      passed++;
      console.log(`PASS ${name}: rejected (${findings.find((f) => f.includes(expect))})`);
    } else {
      failed++;
      console.log(`FAIL ${name}: no finding contains "${expect}"; got:\n  ${findings.join("\n  ") || "(none)"}`);
    }
  }
  console.log(`${passed} passed, ${failed} failed`);
  return failed === 0 && bad.length > 0;
}

const args = process.argv.slice(2);
const dirAt = args.indexOf("--dir");
const dir = resolve(dirAt >= 0 ? args[dirAt + 1] : join(here, "..", "..", "deploy", "kubernetes"));
if (args.includes("--self-test")) {
  process.exit((await selfTest(dir)) ? 0 : 1);
}
const findings = await validate(readSet(dir));
for (const f of findings) console.error(f);
if (findings.length > 0) {
  console.error(`deploy.kubernetes: ${findings.length} problem(s) in ${dir}`);
  process.exit(1);
}
console.log(`deploy.kubernetes: ${readSet(dir).size} files in ${dir} valid (kubernetes-models schemas + rules.mjs)`);
