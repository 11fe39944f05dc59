#!/usr/bin/env bash
# Regenerates caustica_client/ (do not edit it by hand) from api/openapi.yaml with the standard
# generator, openapi-python-client from PyPI at a pinned version, in a private virtual
# environment; records the spec's SHA-256 so a test can say when the client is stale.
set -euo pipefail
cd "$(dirname "$0")"
version=0.29.1
venv=${OPC_VENV:-${TMPDIR:-/tmp}/caustica-openapi-python-client-$version}
if [ ! -x "$venv/bin/openapi-python-client" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q "openapi-python-client==$version"
fi
rm -rf caustica_client
"$venv/bin/openapi-python-client" generate --path ../../api/openapi.yaml --meta none \
  --config generator.yaml --output-path caustica_client
# openapi-python-client 0.29.1 annotates a required body of several media types (POST
# /v1/scenes) with `| Unset` without importing Unset: add the import where it is missing.
grep -rl --include='*.py' 'Unset' caustica_client | while read -r f; do
  grep -q 'import.*\bUnset\b' "$f" || sed -i '0,/^from \.\.\.types import/s//from ...types import Unset\n&/' "$f"
done
sha256sum ../../api/openapi.yaml | cut -d' ' -f1 >SPEC_SHA256
