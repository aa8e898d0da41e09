#!/usr/bin/env bash
# Installs Debian's headless-capable Chromium for the dashboard test (cli/tests/serve_dashboard.rs).
# Idempotent: does nothing when `chromium` is already on the PATH.
set -euo pipefail
if command -v chromium >/dev/null 2>&1; then
    exit 0
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update
apt-get install -y --no-install-recommends chromium
