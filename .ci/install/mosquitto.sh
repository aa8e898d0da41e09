#!/usr/bin/env bash
# Installs the Mosquitto MQTT broker (Debian package) for the `serve` crate's MQTT tests.
# Idempotent: does nothing when `mosquitto` is already on PATH or in /usr/sbin.
set -euo pipefail
if command -v mosquitto >/dev/null 2>&1 || [ -x /usr/sbin/mosquitto ]; then
    exit 0
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update
apt-get install -y --no-install-recommends mosquitto
# The package's own service is not wanted: the tests start their own broker on a free port.
if command -v systemctl >/dev/null 2>&1; then
    systemctl disable --now mosquitto >/dev/null 2>&1 || true
fi
