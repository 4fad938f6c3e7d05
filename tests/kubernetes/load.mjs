// Loads a manifest directory (a Map file name -> text) into documents and checks each against the
// Kubernetes OpenAPI schema compiled into kubernetes-models (offline; see package.json).
import { parseAllDocuments } from "yaml";

// Every finding names file, document index and field: "daemonset.yaml#0 spec.x: message".
export function finding(file, doc, field, message) {
  return `${file}#${doc} ${field || "(document)"}: ${message}`;
}

// apiVersion "v1" -> kubernetes-models/v1, "apps/v1" -> kubernetes-models/apps/v1: the package's
// export map has one entry per group/version, each exporting one class per kind.
async function modelClass(apiVersion, kind) {
  let mod;
  try {
    mod = await import(`kubernetes-models/${apiVersion}`);
  } catch {
    return null;
  }
  return typeof mod[kind] === "function" ? mod[kind] : null;
}

// ajv's instancePath "/spec/template/spec/containers/0" -> "spec.template.spec.containers[0]".
function fieldOf(instancePath) {
  return instancePath
    .split("/")
    .filter((p) => p !== "")
    .map((p, i) => (/^\d+$/.test(p) ? `[${p}]` : (i ? "." : "") + p))
    .join("");
}

// Returns {docs: [{file, index, obj}], kustomization: {file, obj} | null, findings: [...]}.
export async function loadSet(files) {
  const docs = [];
  const findings = [];
  let kustomization = null;
  for (const [file, text] of [...files].sort(([a], [b]) => a.localeCompare(b))) {
    const parsed = parseAllDocuments(text, { uniqueKeys: true, prettyErrors: false });
    const list = Array.isArray(parsed) ? parsed : [parsed];
    let index = 0;
    for (const d of list) {
      const i = index++;
      for (const e of d.errors) findings.push(finding(file, i, "", `YAML: ${e.message}`));
      if (d.errors.length) continue;
      const obj = d.toJS();
      if (obj === null || obj === undefined) continue;
      if (typeof obj !== "object" || Array.isArray(obj)) {
        findings.push(finding(file, i, "", "not a mapping"));
        continue;
      }
      if (obj.kind === "Kustomization") {
        kustomization = { file, obj };
        continue;
      }
      docs.push({ file, index: i, obj });
    }
  }
  for (const { file, index, obj } of docs) {
    for (const key of ["apiVersion", "kind"]) {
      if (typeof obj[key] !== "string") findings.push(finding(file, index, key, "required"));
    }
    if (typeof obj.metadata?.name !== "string" || obj.metadata.name === "") {
      findings.push(finding(file, index, "metadata.name", "required"));
    }
    if (typeof obj.apiVersion !== "string" || typeof obj.kind !== "string") continue;
    const Model = await modelClass(obj.apiVersion, obj.kind);
    if (!Model) {
      findings.push(finding(file, index, "kind", `${obj.apiVersion} ${obj.kind} has no schema`));
      continue;
    }
    try {
      new Model(obj).validate();
    } catch (e) {
      const errors = Array.isArray(e.errors) ? e.errors : [{ instancePath: "", message: e.message }];
      for (const err of errors) {
        const extra = err.params?.missingProperty ? ` (${err.params.missingProperty})` : "";
        findings.push(finding(file, index, fieldOf(err.instancePath), `schema: ${err.message}${extra}`));
      }
    }
  }
  return { docs, kustomization, findings };
}
