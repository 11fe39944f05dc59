#!/usr/bin/env bash
# Compiles the viewer and the TypeScript client it uses into web/dist (committed: the server
# embeds web/dist/web/src/viewer.js and web/dist/clients/typescript/src/index.js). Needs tsc
# (Debian: node-typescript); a test fails while the committed files differ from its output.
set -euo pipefail
cd "$(dirname "$0")"
rm -rf dist
tsc -p .
rm -f dist/clients/typescript/src/schema.js
