#!/usr/bin/env python3
"""Structural and schema checks of deploy/: the Kubernetes manifests, the compose file and the Grafana dashboard.

  check_manifests.py SOURCE_DIR FLEETD FLEETCTL

Exits non-zero naming every problem found. Uses only Debian packages (python3-yaml, python3-jsonschema).
"""
import json
import os
import re
import subprocess
import sys

import jsonschema
import yaml

src, fleetd, fleetctl = sys.argv[1:4]
deploy = os.path.join(src, "deploy")
k8s_dir = os.path.join(deploy, "k8s")
problems = []


def problem(message):
    problems.append(message)
    print("FAIL: " + message)


def flags_of(command):
    """Long options a binary's --help lists."""
    text = subprocess.run(command + ["--help"], capture_output=True, text=True, check=False).stdout
    flags = set(re.findall(r"(--[a-z][a-z0-9-]*)", text))
    if "--help" not in flags:
        problem(f"{' '.join(command)} --help printed no options")
    return flags


fleetd_flags = flags_of([fleetd])
reprocess_flags = flags_of([fleetctl, "reprocess"])


def check_fleetd_args(where, args):
    for arg in args:
        if isinstance(arg, str) and arg.startswith("--"):
            flag = arg.split("=", 1)[0]
            if flag not in fleetd_flags:
                problem(f"{where}: fleetd has no flag {flag}")
    check_no_secrets_in_argv(where, args)


SECRET_VARIABLE = re.compile(r"\$[({](\w*(?:PASSWORD|TOKEN|DB_URL|SECRET)\w*)")


def check_no_secrets_in_argv(where, args):
    """Command lines are readable by every user of the host (/proc/PID/cmdline): secrets go in the environment."""
    for arg in args:
        arg = str(arg)
        if arg.split("=", 1)[0] in ("--db", "--token", "--bootstrap-admin-token"):
            problem(f"{where}: {arg.split('=', 1)[0]} on the command line (use the environment or a file)")
        if re.search(r"://[^/@\s]*:[^/@\s]*@", arg):
            problem(f"{where}: a URL with a password on the command line")
        for variable in SECRET_VARIABLE.findall(arg):
            problem(f"{where}: secret ${variable} spliced into the command line")


def check_tls(where, args, mounts):
    """A gRPC server serves TLS, its certificate and key from a mounted directory."""
    values = {}
    for i, arg in enumerate(args):
        flag, _, value = str(arg).partition("=")
        if flag in ("--tls-cert", "--tls-key"):
            values[flag] = value or (str(args[i + 1]) if i + 1 < len(args) else "")
    for flag in ("--tls-cert", "--tls-key"):
        path = values.get(flag)
        if not path:
            problem(f"{where}: gRPC without {flag} (the shipped topology speaks TLS)")
        elif not any(path.startswith(m.rstrip("/") + "/") for m in mounts):
            problem(f"{where}: {flag} {path} is not under a mounted secret/volume ({sorted(mounts)})")


# ---- Kubernetes -------------------------------------------------------------------------------------------
API = {"Namespace": "v1", "ConfigMap": "v1", "Secret": "v1", "Service": "v1", "Deployment": "apps/v1",
       "StatefulSet": "apps/v1", "Job": "batch/v1", "HorizontalPodAutoscaler": "autoscaling/v2"}
kustomization = yaml.safe_load(open(os.path.join(k8s_dir, "kustomization.yaml")))
listed = kustomization.get("resources", [])
present = sorted(f for f in os.listdir(k8s_dir) if f.endswith(".yaml") and f != "kustomization.yaml")
if sorted(listed) != present:
    problem(f"kustomization resources {sorted(listed)} != manifest files {present}")
image_names = {i["name"] for i in kustomization.get("images", [])}

docs = []
for name in listed:
    for doc in yaml.safe_load_all(open(os.path.join(k8s_dir, name))):
        if doc is None:
            continue
        where = f"{name}: {doc.get('kind')}/{(doc.get('metadata') or {}).get('name')}"
        for key in ("apiVersion", "kind", "metadata"):
            if key not in doc:
                problem(f"{where}: missing {key}")
        if not (doc.get("metadata") or {}).get("name"):
            problem(f"{where}: missing metadata.name")
        if API.get(doc.get("kind")) != doc.get("apiVersion"):
            problem(f"{where}: apiVersion {doc.get('apiVersion')} (expected {API.get(doc.get('kind'))})")
        docs.append((where, doc))

by_kind = {}
for where, doc in docs:
    by_kind.setdefault(doc["kind"], {})[doc["metadata"]["name"]] = doc
configmaps = {n: d.get("data", {}) for n, d in by_kind.get("ConfigMap", {}).items()}
secrets = {n: {**d.get("stringData", {}), **d.get("data", {})} for n, d in by_kind.get("Secret", {}).items()}
workloads = {k: by_kind.get(k, {}) for k in ("Deployment", "StatefulSet", "Job")}
for kind in ("Deployment", "StatefulSet", "Job", "Namespace", "ConfigMap", "Secret", "Service",
             "HorizontalPodAutoscaler"):
    if not by_kind.get(kind):
        problem(f"no {kind} in the manifests")

template_labels = []
for kind, items in workloads.items():
    for name, doc in items.items():
        where = f"{kind}/{name}"
        spec = doc.get("spec", {})
        template = spec.get("template", {})
        labels = template.get("metadata", {}).get("labels", {})
        template_labels.append(labels)
        match = spec.get("selector", {}).get("matchLabels")
        if kind != "Job":
            if not match:
                problem(f"{where}: no spec.selector.matchLabels")
            elif any(labels.get(k) != v for k, v in match.items()):
                problem(f"{where}: selector {match} does not match template labels {labels}")
        pod = template.get("spec", {})
        if kind == "Job" and pod.get("restartPolicy") not in ("OnFailure", "Never"):
            problem(f"{where}: a Job's restartPolicy must be OnFailure or Never")
        if not pod.get("containers"):
            problem(f"{where}: no containers")
        for container in pod.get("containers", []):
            cwhere = f"{where}/{container.get('name')}"
            image = container.get("image", "")
            if not image:
                problem(f"{cwhere}: no image")
            if image.split(":")[0] not in image_names and ":" not in image:
                problem(f"{cwhere}: image {image} is neither pinned nor mapped in kustomization images")
            env = {}
            for ref in container.get("envFrom", []):
                cm = (ref.get("configMapRef") or {}).get("name")
                if cm is not None:
                    if cm not in configmaps:
                        problem(f"{cwhere}: envFrom names missing ConfigMap {cm}")
                    env.update(configmaps.get(cm, {}))
            for var in container.get("env", []):
                env[var["name"]] = var.get("value", "")
                ref = (var.get("valueFrom") or {}).get("secretKeyRef")
                if ref and ref.get("key") not in secrets.get(ref.get("name"), {}):
                    problem(f"{cwhere}: secretKeyRef {ref} names no Secret key")
            args = [str(a) for a in container.get("args", [])]
            for used in re.findall(r"\$\(([A-Z_][A-Z0-9_]*)\)", " ".join(args)):
                if used not in env:
                    problem(f"{cwhere}: args use $({used}) but the container has no such variable")
            ports = {p.get("name") for p in container.get("ports", [])}
            for probe_name in ("readinessProbe", "livenessProbe"):
                probe = container.get(probe_name) or {}
                port = (probe.get("httpGet") or {}).get("port")
                if isinstance(port, str) and port not in ports:
                    problem(f"{cwhere}: {probe_name} port {port} is not a named container port")
            secret_volumes = {v["name"] for v in pod.get("volumes", []) if "secret" in v}
            mounts = {m["mountPath"] for m in container.get("volumeMounts", []) if m.get("name") in secret_volumes}
            if image.split(":")[0] in image_names and not container.get("command"):
                check_fleetd_args(cwhere, args)
                role = args[args.index("--role") + 1] if "--role" in args else "all"
                if role not in ("all", "server", "worker"):
                    problem(f"{cwhere}: --role {role}")
                if role != "worker":
                    check_tls(cwhere, args, mounts)
                    if "grpc" in (container.get("readinessProbe") or {}):
                        problem(f"{cwhere}: a gRPC readiness probe cannot speak TLS; probe /healthz")
                if "FLEETD_DB_URL" not in env:
                    problem(f"{cwhere}: no FLEETD_DB_URL in the environment")
            elif image.split(":")[0] in image_names:
                check_no_secrets_in_argv(cwhere, container.get("command", []) + args)
                if "--token" in " ".join(args):
                    problem(f"{cwhere}: a token on fleetctl's command line")
                ca = env.get("FLEET_TLS_CA", "")
                if not ca or not any(ca.startswith(m.rstrip("/") + "/") for m in mounts):
                    problem(f"{cwhere}: fleetctl without FLEET_TLS_CA under a mounted secret")
        if kind == "Job":
            if spec.get("completionMode") != "Indexed":
                problem(f"{where}: not an Indexed Job")
            script = " ".join(str(a) for c in pod.get("containers", []) for a in c.get("args", []))
            shards = [v.get("value") for c in pod.get("containers", []) for v in c.get("env", [])
                      if v["name"] == "SHARDS"]
            if shards != [str(spec.get("completions"))]:
                problem(f"{where}: SHARDS {shards} != completions {spec.get('completions')}")
            if "JOB_COMPLETION_INDEX" not in script:
                problem(f"{where}: the script does not use JOB_COMPLETION_INDEX")
            for flag in re.findall(r"fleetctl reprocess(.*)", script)[0].split():
                if flag.startswith("--") and flag not in reprocess_flags:
                    problem(f"{where}: fleetctl reprocess has no flag {flag}")

for name, service in by_kind.get("Service", {}).items():
    selector = service.get("spec", {}).get("selector", {})
    targets = [labels for labels in template_labels if all(labels.get(k) == v for k, v in selector.items())]
    if not selector or not targets:
        problem(f"Service/{name}: selector {selector} matches no workload")
for name, hpa in by_kind.get("HorizontalPodAutoscaler", {}).items():
    target = hpa["spec"]["scaleTargetRef"]
    if target.get("name") not in workloads.get(target.get("kind"), {}):
        problem(f"HorizontalPodAutoscaler/{name}: scaleTargetRef {target} names no workload")
    if hpa["spec"].get("minReplicas", 1) > hpa["spec"]["maxReplicas"]:
        problem(f"HorizontalPodAutoscaler/{name}: minReplicas > maxReplicas")
print(f"k8s: {len(docs)} objects checked")

# ---- compose ----------------------------------------------------------------------------------------------
COMPOSE_SCHEMA = {
    "type": "object", "required": ["services"],
    "properties": {
        "name": {"type": "string"},
        "services": {"type": "object", "minProperties": 1, "additionalProperties": {
            "type": "object", "anyOf": [{"required": ["image"]}, {"required": ["build"]}],
            "properties": {
                "image": {"type": "string"}, "command": {"type": "array", "items": {"type": "string"}},
                "environment": {"type": "object", "additionalProperties": {"type": ["string", "number"]}},
                "ports": {"type": "array", "items": {"type": "string", "pattern": r"^([0-9.]+:)?[0-9]+:[0-9]+$"}},
                "depends_on": {"type": "object", "additionalProperties": {
                    "type": "object", "properties": {"condition": {"enum": [
                        "service_started", "service_healthy", "service_completed_successfully"]}}}},
                "healthcheck": {"type": "object", "required": ["test"],
                                "properties": {"test": {"type": "array", "items": {"type": "string"}}}},
                "restart": {"enum": ["no", "always", "on-failure", "unless-stopped"]},
                "build": {"type": "object", "required": ["context"]},
                "volumes": {"type": "array", "items": {"type": "string"}},
            }, "additionalProperties": False}},
        "volumes": {"type": "object"},
    },
    "patternProperties": {"^x-": {}}, "additionalProperties": False,
}
compose = yaml.safe_load(open(os.path.join(deploy, "compose.yaml")))
try:
    jsonschema.validate(compose, COMPOSE_SCHEMA)
except jsonschema.ValidationError as error:
    problem(f"compose.yaml: {error.message} at {list(error.absolute_path)}")
services = compose.get("services", {})
roles = {}
compose_text = open(os.path.join(deploy, "compose.yaml")).read()
for variable in re.findall(r"\$\{(\w*(?:PASSWORD|TOKEN)\w*):-", compose_text):
    problem(f"compose.yaml: secret ${{{variable}}} has a default value (use ${{{variable}:?...}})")
for name, service in services.items():
    if "postgres" in service.get("image", ""):
        continue
    command = service.get("command", [])
    check_fleetd_args(f"compose.yaml {name}", command)
    role = next((c.split("=", 1)[1] for c in command if c.startswith("--role=")), "all")
    roles.setdefault(role, []).append(name)
    if not str(service.get("environment", {}).get("FLEETD_DB_URL", "")).startswith("postgresql://"):
        problem(f"compose.yaml {name}: not on PostgreSQL (FLEETD_DB_URL in its environment)")
    if role != "worker":
        check_tls(f"compose.yaml {name}", command,
                  {v.split(":")[1] for v in service.get("volumes", []) if v.count(":") >= 1})
    if "postgres" not in service.get("depends_on", {}):
        problem(f"compose.yaml {name}: does not wait for postgres")
    for volume in service.get("volumes", []):
        if ":" in volume and volume.split(":")[0] not in compose.get("volumes", {}) and not volume.startswith((".", "/")):
            problem(f"compose.yaml {name}: unknown volume {volume}")
if len(roles.get("server", [])) != 2 or len(roles.get("worker", [])) != 2:
    problem(f"compose.yaml: expected two servers and two workers, got {roles}")
print(f"compose: {len(services)} services checked ({roles})")

# ---- Grafana dashboard ------------------------------------------------------------------------------------
DASHBOARD_SCHEMA = {
    "type": "object", "required": ["title", "uid", "panels", "schemaVersion", "templating"],
    "properties": {"panels": {"type": "array", "minItems": 1, "items": {
        "type": "object", "required": ["id", "type", "title", "gridPos", "datasource", "targets"],
        "properties": {
            "gridPos": {"type": "object", "required": ["x", "y", "w", "h"]},
            "datasource": {"type": "object", "properties": {"type": {"const": "grafana-postgresql-datasource"}}},
            "targets": {"type": "array", "minItems": 1, "items": {
                "type": "object", "required": ["refId", "rawSql", "format"],
                "properties": {"format": {"enum": ["time_series", "table"]}, "rawSql": {"type": "string"}}}}}}}},
}
try:
    dashboard = json.load(open(os.path.join(deploy, "grafana", "fleet-dashboard.json")))
    jsonschema.validate(dashboard, DASHBOARD_SCHEMA)
except (ValueError, jsonschema.ValidationError) as error:
    problem(f"grafana/fleet-dashboard.json: {error}")
    dashboard = {"panels": []}

# Every alias.column in the panels' SQL must exist in the schema the storage migrations create.
migrations = open(os.path.join(src, "storage", "src", "migrations.cc")).read()
tables = {}
for table, body in re.findall(r"CREATE TABLE (?:IF NOT EXISTS )?(\w+) \((.*?)\n\);", migrations, re.S):
    tables[table] = {line.split()[0] for line in body.strip().splitlines()
                     if line.strip() and not line.strip().startswith(("PRIMARY", "FOREIGN"))}
ids = set()
for panel in dashboard["panels"]:
    if panel["id"] in ids:
        problem(f"dashboard: duplicate panel id {panel['id']}")
    ids.add(panel["id"])
    for target in panel["targets"]:
        sql = target["rawSql"]
        aliases = dict((alias, table) for table, alias in re.findall(r"(?:FROM|JOIN) (\w+) (\w+)", sql))
        for table in re.findall(r"(?:FROM|JOIN) (\w+)", sql):
            if table not in tables:
                problem(f"dashboard panel '{panel['title']}': unknown table {table}")
        for alias, column in re.findall(r"\b([a-z])\.(\w+)", sql):
            table = aliases.get(alias)
            if table is None or column not in tables.get(table, ()):
                problem(f"dashboard panel '{panel['title']}': {alias}.{column} is not a column of {table}")
        if not aliases or any(not re.fullmatch(r"[a-z]", a) for a in aliases):
            problem(f"dashboard panel '{panel['title']}': give every table a one-letter alias so columns are checked")
print(f"grafana: {len(dashboard['panels'])} panels checked against {len(tables)} tables")

# ---- placeholder secrets ----------------------------------------------------------------------------------
# The built fleetd refuses to start with the placeholder values the Secret ships (before touching a database).
placeholders = secrets.get("fleetd-secrets", {})
for key in ("FLEETD_BOOTSTRAP_ADMIN_TOKEN", "FLEETD_DB_URL"):
    env = {k: v for k, v in os.environ.items() if not k.startswith("FLEETD_")}
    env[key] = placeholders.get(key, "")
    try:
        run = subprocess.run([fleetd, "--listen", "127.0.0.1:0", "--http", "", "--role", "server"]
                             + (["--db", "sqlite::memory:"] if key != "FLEETD_DB_URL" else []),
                             env=env, capture_output=True, text=True, timeout=10, check=False)
        refused, said = run.returncode == 2 and "placeholder" in run.stderr, f"exit {run.returncode}: {run.stderr.strip()}"
    except subprocess.TimeoutExpired:
        refused, said = False, "it kept running"
    if not refused:
        problem(f"fleetd started with the placeholder {key} of secret.yaml ({said})")
print("placeholders: fleetd refuses the shipped FLEETD_BOOTSTRAP_ADMIN_TOKEN and FLEETD_DB_URL")

if problems:
    print(f"{len(problems)} problem(s)")
    sys.exit(1)
print("deploy manifests: OK")
