// Our own rules for deploy/kubernetes (issue 9, docs/deployment.md): what the schema cannot say,
// e.g. that the gateway owns the node's buses (hostNetwork, nodeSelector), runs non-root, is
// probed on its health endpoints and is the only writer of its SQLite file.
import { parse } from "yaml";
import { finding } from "./load.mjs";

const kHttpPort = 8080;
const kGrpcPort = 50051;
const kUid = 10001;
const kBusOwnerLabel = "drivegw.io/bus-owner";
// Capabilities the container may add: none. CAN_RAW sockets check none (net/can/af_can.c
// can_create), a tty opens by its group; CAP_NET_ADMIN for `ip link set can0 up` is the node's.
const kAllowedCapabilities = new Set();
const kDefaultShutdownTimeoutS = 10; // docs/config.md, shutdown_timeout_s

function byKind(docs, kind) {
  return docs.filter((d) => d.obj.kind === kind);
}

function named(docs, kind, name) {
  return docs.find((d) => d.obj.kind === kind && d.obj.metadata?.name === name);
}

// Resolves a probe or Service port (number or container port name) to a number.
function portNumber(port, container) {
  if (typeof port === "number") return port;
  const p = (container.ports ?? []).find((cp) => cp.name === port);
  return p ? p.containerPort : undefined;
}

// Gateway configurations of every ConfigMap key ending in .yaml: [{where, cfg}].
function gatewayConfigs(docs, out) {
  const configs = [];
  for (const d of byKind(docs, "ConfigMap")) {
    for (const [key, text] of Object.entries(d.obj.data ?? {})) {
      if (!key.endsWith(".yaml")) continue;
      const where = `data["${key}"]`;
      try {
        configs.push({ d, where, cfg: parse(text, { uniqueKeys: true }) ?? {} });
      } catch (e) {
        out.push(finding(d.file, d.index, where, `gateway config is not YAML: ${e.message}`));
      }
    }
  }
  return configs;
}

function checkProbe(at, container, probe, field, paths, scheme) {
  if (!probe) return at(field, "required");
  const get = probe.httpGet;
  if (!get) return at(`${field}.httpGet`, "required (GET on the HTTP port)");
  if (!paths.includes(get.path)) at(`${field}.httpGet.path`, `${get.path} is not ${paths.join(" or ")}`);
  const port = portNumber(get.port, container);
  if (port !== kHttpPort) at(`${field}.httpGet.port`, `${get.port} is not the HTTP port ${kHttpPort}`);
  if ((get.scheme ?? "HTTP") !== scheme) {
    at(`${field}.httpGet.scheme`, `${get.scheme ?? "HTTP"} but the gateway config says ${scheme}`);
  }
}

function checkDaemonSet(docs, d, configs, out) {
  const at = (field, msg) => out.push(finding(d.file, d.index, field, msg));
  const spec = d.obj.spec ?? {};
  const pod = spec.template?.spec ?? {};
  const P = "spec.template.spec";
  if (pod.nodeSelector?.[kBusOwnerLabel] !== "true") at(`${P}.nodeSelector`, `needs ${kBusOwnerLabel}: "true"`);
  if (pod.hostNetwork !== true) at(`${P}.hostNetwork`, "must be true (SocketCAN interfaces are in the node's netns)");
  if (pod.dnsPolicy !== "ClusterFirstWithHostNet") at(`${P}.dnsPolicy`, "must be ClusterFirstWithHostNet with hostNetwork");
  const surge = spec.updateStrategy?.rollingUpdate?.maxSurge;
  if (surge !== undefined && surge !== 0 && surge !== "0%") {
    at("spec.updateStrategy.rollingUpdate.maxSurge", `${surge}: two gateways on a node would both write drivegw.db`);
  }
  const containers = pod.containers ?? [];
  const c = containers.find((x) => x.name === "drivegw");
  if (!c) return at(`${P}.containers`, 'no container named "drivegw"');
  const C = `${P}.containers[${containers.indexOf(c)}]`;
  const psc = pod.securityContext ?? {};
  const csc = c.securityContext ?? {};
  if ((csc.runAsNonRoot ?? psc.runAsNonRoot) !== true) at(`${C}.securityContext.runAsNonRoot`, "must be true");
  if ((csc.runAsUser ?? psc.runAsUser) !== kUid) at(`${C}.securityContext.runAsUser`, `must be ${kUid} (the image's user)`);
  if (csc.readOnlyRootFilesystem !== true) at(`${C}.securityContext.readOnlyRootFilesystem`, "must be true");
  if (csc.allowPrivilegeEscalation !== false) at(`${C}.securityContext.allowPrivilegeEscalation`, "must be false");
  if (csc.privileged === true) at(`${C}.securityContext.privileged`, "must not be true");
  if (!(csc.capabilities?.drop ?? []).includes("ALL")) at(`${C}.securityContext.capabilities.drop`, "must include ALL");
  for (const cap of csc.capabilities?.add ?? []) {
    if (!kAllowedCapabilities.has(cap)) at(`${C}.securityContext.capabilities.add`, `${cap} is not needed (docs/deployment.md)`);
  }
  for (const [port, name] of [[kGrpcPort, "grpc"], [kHttpPort, "http"]]) {
    if (!(c.ports ?? []).some((p) => p.containerPort === port && p.name === name)) {
      at(`${C}.ports`, `needs ${name} on ${port}`);
    }
  }
  if (!c.resources?.requests?.cpu || !c.resources?.requests?.memory) at(`${C}.resources.requests`, "cpu and memory required");
  if (!c.resources?.limits?.memory) at(`${C}.resources.limits.memory`, "required");

  const tls = configs.some(({ cfg }) => cfg.tls !== undefined);
  const scheme = tls ? "HTTPS" : "HTTP";
  checkProbe(at, c, c.livenessProbe, `${C}.livenessProbe`, ["/healthz"], scheme);
  checkProbe(at, c, c.readinessProbe, `${C}.readinessProbe`, ["/readyz"], scheme);
  checkProbe(at, c, c.startupProbe, `${C}.startupProbe`, ["/healthz", "/readyz"], scheme);

  const longest = Math.max(kDefaultShutdownTimeoutS, ...configs.map(({ cfg }) => cfg.shutdown_timeout_s ?? kDefaultShutdownTimeoutS));
  const grace = pod.terminationGracePeriodSeconds ?? 30;
  if (!(grace > longest)) at(`${P}.terminationGracePeriodSeconds`, `${grace} must exceed shutdown_timeout_s ${longest}`);

  // Volumes: every mount has its volume; /data, /etc/drivegw and each serial device are mounted.
  const volumes = new Map((pod.volumes ?? []).map((v) => [v.name, v]));
  const mounts = new Map((c.volumeMounts ?? []).map((m) => [m.mountPath, m]));
  (c.volumeMounts ?? []).forEach((m, i) => {
    if (!volumes.has(m.name)) at(`${C}.volumeMounts[${i}].name`, `no volume named ${m.name}`);
  });
  const devices = new Set(["/dev/ttyUSB0"]);
  for (const { cfg } of configs) {
    for (const drive of cfg.drives ?? []) {
      if (drive?.trinamic?.serial?.device) devices.add(drive.trinamic.serial.device);
    }
  }
  for (const path of ["/data", "/etc/drivegw", ...devices]) {
    if (!mounts.has(path)) at(`${C}.volumeMounts`, `nothing mounted at ${path}`);
  }
  const data = volumes.get(mounts.get("/data")?.name);
  if (data) checkDataVolume(docs, data, at, out);
  for (const path of devices) {
    const v = volumes.get(mounts.get(path)?.name);
    if (v && !(v.hostPath?.path === path && v.hostPath?.type === "CharDevice")) {
      at(`${P}.volumes[${v.name}]`, `${path} must be a hostPath of type CharDevice`);
    }
  }
  const config = volumes.get(mounts.get("/etc/drivegw")?.name);
  if (config) checkConfigVolume(docs, config, configs, at, out);
}

// SQLite in WAL mode: a local filesystem and one writer (docs/deployment.md). A hostPath on the
// node, or a claim that exists and is bound to an existing local PV pinned to a node.
function checkDataVolume(docs, v, at, out) {
  const f = `spec.template.spec.volumes[${v.name}]`;
  if (v.hostPath) {
    if (v.hostPath.type !== "Directory") at(`${f}.hostPath.type`, "must be Directory (prepared by the node set-up)");
    return;
  }
  const claim = v.persistentVolumeClaim?.claimName;
  if (!claim) return at(f, "/data must be a hostPath or a persistentVolumeClaim (local disk)");
  const pvc = named(docs, "PersistentVolumeClaim", claim);
  if (!pvc) return at(`${f}.persistentVolumeClaim.claimName`, `no PersistentVolumeClaim named ${claim}`);
  const pvName = pvc.obj.spec?.volumeName;
  const pv = pvName && named(docs, "PersistentVolume", pvName);
  if (!pv) {
    return out.push(finding(pvc.file, pvc.index, "spec.volumeName", `${pvName ?? "(none)"} names no PersistentVolume here`));
  }
  if (!pv.obj.spec?.local || !pv.obj.spec?.nodeAffinity) {
    out.push(finding(pv.file, pv.index, "spec.local", "must be a local PV with a nodeAffinity (no NFS for SQLite WAL)"));
  }
}

function checkConfigVolume(docs, v, configs, at, out) {
  const f = `spec.template.spec.volumes[${v.name}]`;
  const sources = v.projected?.sources ?? (v.configMap ? [{ configMap: v.configMap }] : []);
  const files = new Set();
  for (const s of sources) {
    const ref = s.configMap ?? s.secret;
    const kind = s.configMap ? "ConfigMap" : s.secret ? "Secret" : null;
    if (!kind) continue;
    const target = named(docs, kind, ref.name);
    if (!target) {
      at(`${f}`, `no ${kind} named ${ref.name}`);
      continue;
    }
    const keys = new Set([...Object.keys(target.obj.data ?? {}), ...Object.keys(target.obj.stringData ?? {})]);
    for (const item of ref.items ?? []) {
      if (!keys.has(item.key)) at(`${f}`, `${kind} ${ref.name} has no key ${item.key}`);
      files.add(`/etc/drivegw/${item.path}`);
    }
    if (!ref.items) for (const k of keys) files.add(`/etc/drivegw/${k}`);
  }
  for (const { d: cm, where, cfg } of configs) {
    const here = (field, msg) => out.push(finding(cm.file, cm.index, `${where}.${field}`, msg));
    if (cfg.data_dir !== "/data") here("data_dir", `${cfg.data_dir} is not the mounted /data`);
    if (!String(cfg.listen?.http ?? "").endsWith(`:${kHttpPort}`)) here("listen.http", `must end in :${kHttpPort}`);
    if (!String(cfg.listen?.grpc ?? "").endsWith(`:${kGrpcPort}`)) here("listen.grpc", `must end in :${kGrpcPort}`);
    if (cfg.auth?.enabled !== true) here("auth.enabled", "must be true: the gateway listens on the node's network");
    if (cfg.tls?.require_client_cert === true) here("tls.require_client_cert", "true refuses the kubelet's probes");
    for (const key of ["cert", "key", "client_ca"]) {
      const path = cfg.tls?.[key];
      if (path !== undefined && !files.has(path)) here(`tls.${key}`, `${path} is not a file of the mounted volume`);
    }
  }
}

function checkServices(docs, ds, out) {
  const labels = ds?.obj.spec?.template?.metadata?.labels ?? {};
  const container = (ds?.obj.spec?.template?.spec?.containers ?? []).find((c) => c.name === "drivegw") ?? {};
  const services = byKind(docs, "Service");
  for (const s of services) {
    const at = (field, msg) => out.push(finding(s.file, s.index, field, msg));
    const sel = s.obj.spec?.selector ?? {};
    if (Object.keys(sel).length === 0) at("spec.selector", "required");
    for (const [k, v] of Object.entries(sel)) {
      if (labels[k] !== v) at(`spec.selector.${k}`, `${v} does not match the DaemonSet's pod label (${labels[k] ?? "absent"})`);
    }
    (s.obj.spec?.ports ?? []).forEach((p, i) => {
      const target = portNumber(p.targetPort ?? p.port, container);
      if (target !== kHttpPort && target !== kGrpcPort) at(`spec.ports[${i}].targetPort`, `${p.targetPort} is no gateway port`);
    });
  }
  if (!services.some((s) => s.obj.spec?.clusterIP === "None")) {
    out.push(finding("service.yaml", 0, "spec.clusterIP", "no headless Service (clusterIP: None) for per-node addressing"));
  }
  if (!services.some((s) => s.obj.spec?.clusterIP !== "None")) {
    out.push(finding("service.yaml", 0, "spec.type", "no ClusterIP Service"));
  }
}

function checkNamespaces(docs, kustomization, out) {
  const ns = byKind(docs, "Namespace").map((d) => d.obj.metadata?.name);
  if (ns.length !== 1) out.push(finding("namespace.yaml", 0, "kind", `want one Namespace, have ${ns.length}`));
  const want = kustomization?.obj.namespace ?? ns[0];
  if (kustomization && kustomization.obj.namespace !== ns[0]) {
    out.push(finding(kustomization.file, 0, "namespace", `${kustomization.obj.namespace} is not the Namespace ${ns[0]}`));
  }
  for (const d of docs) {
    if (d.obj.kind === "Namespace" || d.obj.kind === "PersistentVolume") continue;
    if (d.obj.metadata?.namespace !== want) {
      out.push(finding(d.file, d.index, "metadata.namespace", `${d.obj.metadata?.namespace ?? "absent"}, want ${want}`));
    }
  }
}

// The kustomization must list exactly the manifest files of the directory.
function checkKustomization(files, kustomization, out) {
  if (!kustomization) return out.push(finding("kustomization.yaml", 0, "", "missing"));
  const { file, obj } = kustomization;
  if (obj.apiVersion !== "kustomize.config.k8s.io/v1beta1") out.push(finding(file, 0, "apiVersion", "want kustomize.config.k8s.io/v1beta1"));
  const listed = new Set(obj.resources ?? []);
  for (const f of files.keys()) {
    if (f !== file && !listed.has(f)) out.push(finding(file, 0, "resources", `${f} is not listed`));
  }
  for (const r of listed) if (!files.has(r)) out.push(finding(file, 0, "resources", `${r} does not exist`));
}

export function checkRules(files, { docs, kustomization }) {
  const out = [];
  const configs = gatewayConfigs(docs, out);
  const daemonSets = byKind(docs, "DaemonSet");
  if (daemonSets.length !== 1) out.push(finding("daemonset.yaml", 0, "kind", `want one DaemonSet, have ${daemonSets.length}`));
  for (const d of daemonSets) checkDaemonSet(docs, d, configs, out);
  checkServices(docs, daemonSets[0], out);
  checkNamespaces(docs, kustomization, out);
  checkKustomization(files, kustomization, out);
  return out;
}
