#!/usr/bin/env bash
# Installs the single-node Slurm the Slurm tests start (slurmctld, slurmd, the client commands)
# and munge, from Debian's packages; does nothing when they are already there.
set -euo pipefail
need=()
for tool in slurmctld slurmd sbatch squeue scontrol scancel munged; do
    command -v "$tool" >/dev/null 2>&1 || need+=("$tool")
done
if [ "${#need[@]}" -eq 0 ]; then
    exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
    echo "slurm.sh: missing ${need[*]}; run this script as root to install slurm-wlm and munge" >&2
    exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update
apt-get install -y --no-install-recommends slurm-wlm munge
