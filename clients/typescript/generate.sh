#!/usr/bin/env bash
# Regenerates src/schema.ts (do not edit it by hand): the API's types from api/openapi.yaml by
# the standard generator, openapi-typescript from npm at a pinned version; records the spec's
# SHA-256 so a test can say when the types are stale.
set -euo pipefail
cd "$(dirname "$0")"
# --default-non-nullable false: a request field with a default stays optional in the types.
npx --yes openapi-typescript@7.13.0 ../../api/openapi.yaml -o src/schema.ts --default-non-nullable false
sha256sum ../../api/openapi.yaml | cut -d' ' -f1 >SPEC_SHA256
