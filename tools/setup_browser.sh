#!/usr/bin/env bash
# Installs what the viewer and its browser tests need, only when it is missing:
#   - Debian's chromium (/usr/bin/chromium) and node + npm, with apt-get;
#   - three, playwright-core and gltf-validator into node_modules/, with `npm ci` from package-lock.json.
# Safe to run again: with everything present it changes nothing. Usage: bash tools/setup_browser.sh
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi

missing=()
[ -x /usr/bin/chromium ] || missing+=(chromium)
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup_browser: installing ${missing[*]} with apt-get"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if [ ! -f "$repo/node_modules/three/package.json" ] || [ ! -f "$repo/node_modules/playwright-core/package.json" ] \
   || [ ! -f "$repo/node_modules/gltf-validator/package.json" ]; then
  echo "setup_browser: npm ci (three, playwright-core, gltf-validator)"
  (cd "$repo" && npm ci --no-audit --no-fund --loglevel=error)
fi
