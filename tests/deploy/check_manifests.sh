#!/usr/bin/env bash
# CI check of deploy/: yamllint over the compose file, the Kubernetes manifests and the Grafana provisioning;
# `kubectl kustomize` rendering when kubectl is installed; then check_manifests.py (structure, schemas,
# selectors/labels, ConfigMap/Secret references, fleetd/fleetctl flags against the binaries' --help, the
# Grafana SQL against the storage schema).
#   check_manifests.sh SOURCE_DIR FLEETD FLEETCTL
set -euo pipefail
src=$(realpath "$1") fleetd=$(realpath "$2") fleetctl=$(realpath "$3")
cd "$src/deploy"
# Debian's python3 (python3-yaml, python3-jsonschema); another python3 may come first on PATH.
py=/usr/bin/python3
[[ -x $py ]] || py=python3

command -v yamllint >/dev/null || { echo "FAIL: yamllint missing; run deploy/bootstrap.sh"; exit 1; }
yamllint -c .yamllint --strict compose.yaml k8s grafana/datasource.yaml .yamllint
echo "yamllint: OK"

if command -v kubectl >/dev/null; then
  rendered=$(kubectl kustomize k8s)
  count=$(grep -c '^kind:' <<<"$rendered")
  echo "kubectl kustomize: rendered $count objects"
  [[ $count -ge 10 ]] || { echo "FAIL: kustomize rendered only $count objects"; exit 1; }
else
  echo "kubectl not installed (it is not a Debian package): kustomization checked by check_manifests.py instead"
fi

"$py" "$src/tests/deploy/check_manifests.py" "$src" "$fleetd" "$fleetctl"
