#!/usr/bin/env bash
# action.yml, first use: install franka-sim, start it in the background for the rest of the job,
# wait until it is ready, and give its address. Every server started goes into
# $RUNNER_TEMP/franka-sim/servers (pid and address) for stop.sh; its log into logs/.
set -euo pipefail

dir="${RUNNER_TEMP:?}/franka-sim"
host="${FRANKA_SIM_ACTION_HOST:-127.0.0.1}"
port="${FRANKA_SIM_ACTION_CONTROL_PORT:-1340}"
wait_s="${FRANKA_SIM_ACTION_WAIT:-60}"
mkdir -p "$dir/logs"

alive() {  # a process that has exited but was not reaped yet (a zombie) is not
    local state
    state="$(ps -p "$1" -o stat= 2>/dev/null)" && [ "${state#Z}" = "$state" ]
}

fail() {
    echo "::error title=franka-sim::$1"
    exit 1
}

case "${FRANKA_SIM_ACTION_INSTALL:-true}" in
    true)
        # Default: the franka-sim this action belongs to (the ref the workflow `uses:`), not
        # a package index's: the name franka-sim on PyPI is another project's.
        requirement="${FRANKA_SIM_ACTION_PACKAGE:-$(cd "$(dirname "$0")/../.." && pwd)}"
        if [ ! -x "$dir/venv/bin/franka-sim" ]; then  # a second robot reuses the first's
            python3 -m venv "$dir/venv"
            "$dir/venv/bin/pip" install --quiet --disable-pip-version-check "$requirement" ||
                fail "pip could not install $requirement"
        fi
        sim="$dir/venv/bin/franka-sim" ;;
    false)
        sim="$(command -v franka-sim)" || fail "install is false, and no franka-sim is on PATH" ;;
    *)
        fail "install must be true or false, not '${FRANKA_SIM_ACTION_INSTALL}'" ;;
esac

log="$dir/logs/franka-sim-$host.log"
# What it serves, written once every robot listens: the args may name other addresses (--arm,
# --mobile-base), another control port or a token, which the check then asks.
serving="$dir/serving-$host.json"
rm -f "$serving"
# shellcheck disable=SC2086  # the extra flags are meant to split into words
FRANKA_SIM_SERVING_FILE="$serving" nohup "$sim" serve --host "$host" --control-port "$port" \
    ${FRANKA_SIM_ACTION_ARGS:-} >"$log" 2>&1 </dev/null &
server=$!
echo "$server $host" >>"$dir/servers"

# Ready when `franka-sim check` says so; a server that exits first (a taken port, a bad flag)
# ends the wait at once.
"$sim" check --serving-file "$serving" --wait "$wait_s" &
checker=$!
while alive "$checker"; do
    if ! alive "$server"; then
        kill "$checker" 2>/dev/null || true
        break
    fi
    sleep 0.2
done
if ! wait "$checker"; then
    kill -TERM "$server" 2>/dev/null || true
    echo "--- $log"
    tail -n 20 "$log"
    fail "franka-sim did not become ready on $host within ${wait_s} s (its log is above)"
fi

# The first robot it serves (the args' first --arm, if any), as the serving file says (one
# line of JSON; in the token, were it to hold such text, the quotes are escaped).
host="$(sed -n 's/^.*"robots": \[{[^}]*"host": "\([^"]*\)".*$/\1/p' "$serving")"
port="$(sed -n 's/^.*"robots": \[{[^}]*"control_port": \([0-9]*\).*$/\1/p' "$serving")"
echo "franka-sim ready on $host (log: $log)"
{
    echo "host=$host"
    if [ "$port" != 0 ]; then echo "control-url=http://$host:$port"; else echo "control-url="; fi
    echo "log=$log"
} >>"${GITHUB_OUTPUT:-/dev/stdout}"
