#!/usr/bin/env bash
# action.yml with stop: true: stop every franka-sim that start.sh started in this job (SIGTERM,
# then SIGKILL after 5 s) and name the folder of their logs, for the artifact.
set -euo pipefail

dir="${RUNNER_TEMP:?}/franka-sim"
if [ ! -f "$dir/servers" ]; then
    echo "no franka-sim was started in this job"
    exit 0
fi

alive() {  # a process that has exited but was not reaped yet (a zombie) is not
    local state
    state="$(ps -p "$1" -o stat= 2>/dev/null)" && [ "${state#Z}" = "$state" ]
}

pids=()
while read -r pid host; do
    # Only a process that still is the server (a pid may have been reused since). Its whole
    # command line (-ww): ps cuts it at $COLUMNS otherwise, and a venv's long path then hides
    # the name, which would leave the server running.
    args="$(ps -ww -p "$pid" -o args= 2>/dev/null)" || args=""
    if [[ "$args" =~ franka[-_]sim ]]; then
        kill -TERM "$pid"
        pids+=("$pid")
        echo "stopping franka-sim on $host (pid $pid)"
    fi
done <"$dir/servers"
rm -f "$dir/servers"

for _ in $(seq 50); do
    alive=0
    for pid in "${pids[@]}"; do
        if alive "$pid"; then alive=1; fi
    done
    [ "$alive" = 1 ] || break
    sleep 0.1
done
for pid in "${pids[@]}"; do
    if alive "$pid"; then
        echo "::warning title=franka-sim::pid $pid ignored SIGTERM for 5 s: killed"
        kill -KILL "$pid" 2>/dev/null || true
    fi
done

echo "log-dir=$dir/logs" >>"${GITHUB_OUTPUT:-/dev/stdout}"
