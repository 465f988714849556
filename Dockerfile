# A simulated Franka FR3 + Hand, served as `franka-sim serve` (docs/deployment.md).
#
#   docker build -t franka-sim .
#   docker run --rm -p 127.0.0.1:1337:1337 -p 127.0.0.1:1338:1338 -p 127.0.0.1:1340:1340 franka-sim
#   docker run --rm --network host -e FRANKA_SIM_HOST=127.0.0.2 franka-sim
#   docker run --rm -p 127.0.0.1:1337:1337 -p 127.0.0.1:1338:1338 -p 127.0.0.1:1340:1340 \
#       -p 127.0.0.1:443:443 -e FRANKA_SIM_DESK_PORT=443 franka-sim --desk-boot locked
#   docker run --rm --network host -v recordings:/home/franka-sim/recordings franka-sim \
#       --arm left=127.0.0.2 --arm right=127.0.0.3 --scene dual_arm_table \
#       --record /home/franka-sim/recordings/run.mcap
#
# Build arguments:
#   BASE_IMAGE  any image with python3 (>= 3.11, with its venv module) and useradd; both stages
#               use it, so the virtual environment built in the first runs in the second.
#   WHEELHOUSE  a directory of the build context; when it holds wheels, every package (the build
#               backend too) comes from it alone (pip --no-index): the build needs no network.

ARG BASE_IMAGE=python:3.11-slim

# --- build: the wheel from this source tree, installed into /opt/franka-sim ---------------------
FROM ${BASE_IMAGE} AS build
ARG WHEELHOUSE=wheelhouse
# The package's extras the image carries: `web` serves the web view (docs/viewing.md; ~47 MB),
# `record` records (--record, the control API's POST /recording) and replays (docs/recording.md;
# mcap and lz4, 6 MB; zstandard comes with `web`). `--build-arg EXTRAS=` leaves both out.
ARG EXTRAS=web,record
ENV PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_ROOT_USER_ACTION=ignore
WORKDIR /src
# The context is filtered by .dockerignore: the package sources, and the wheelhouse if any.
COPY . .
# zig's clang (the package's `zig` extra: ~410 MB), in a virtual environment of its own that the
# runtime stage does not copy, is this stage's C compiler: the runtime has none.
RUN set -eu; \
    from=""; \
    if ls "$WHEELHOUSE"/*.whl >/dev/null 2>&1; then \
        from="--no-index --find-links $WHEELHOUSE"; \
    fi; \
    zig=$(python3 -c 'import tomllib; project = tomllib.load(open("pyproject.toml", "rb")); \
        print(*project["project"]["optional-dependencies"]["zig"])'); \
    python3 -m venv /tmp/zig; \
    /tmp/zig/bin/pip install --quiet $from "$zig"
# The wheel, with the cycle's kernels compiled by zig's clang (franka_sim.kernels; where the
# base image has no Python headers the wheel is pure Python and says so: the same robot, a
# slower cycle, docs/benchmarks.md).
RUN set -eu; \
    from=""; \
    if ls "$WHEELHOUSE"/*.whl >/dev/null 2>&1; then \
        from="--no-index --find-links $WHEELHOUSE"; \
    fi; \
    python3 -m venv /opt/franka-sim; \
    CC="/tmp/zig/bin/python -m ziglang cc" \
        /opt/franka-sim/bin/pip wheel --quiet $from --no-deps --wheel-dir /dist .; \
    wheel=$(ls /dist/franka_sim-*.whl); \
    /opt/franka-sim/bin/pip install --quiet $from "$wheel${EXTRAS:+[$EXTRAS]}"; \
    /opt/franka-sim/bin/pip uninstall --quiet --yes pip setuptools 2>/dev/null || true; \
    find /opt/franka-sim -path '*/numpy/*' -type d -name tests -prune -exec rm -rf {} +
# The model library older libfranka clients (0.9-0.17) load, prebuilt for each packaged robot
# (fr3, fer) and Linux x86_64 and aarch64, cross-compiled by the same zig; the libraries
# (~85 KB each) are in /opt/franka-sim/share/model-libraries, which FRANKA_SIM_MODEL_LIBRARIES
# names below.
RUN set -eu; \
    /opt/franka-sim/bin/python -m franka_sim.model_library /opt/franka-sim/share/model-libraries \
        --cc "/tmp/zig/bin/python -m ziglang cc"

# --- runtime: the environment alone, run by an unprivileged user -------------------------------
FROM ${BASE_IMAGE}
COPY --from=build /opt/franka-sim /opt/franka-sim
RUN useradd --uid 10001 --user-group --create-home --home-dir /home/franka-sim \
        --shell /usr/sbin/nologin franka-sim
USER 10001:10001
WORKDIR /home/franka-sim
# The folders a volume is mounted on (the Desk's certificate, recordings): a named volume
# mounted on a folder of the image takes its owner, this user's; on one it lacks, root's.
RUN mkdir -p /home/franka-sim/.local/share/franka-sim/desk /home/franka-sim/recordings \
    && chmod 700 /home/franka-sim/.local/share/franka-sim/desk
ENV PATH=/opt/franka-sim/bin:$PATH \
    PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    FRANKA_SIM_HOST=0.0.0.0 \
    FRANKA_SIM_MODEL_LIBRARIES=/opt/franka-sim/share/model-libraries \
    FRANKA_SIM_SERVING_FILE=/tmp/franka-sim-serving.json

# The robot (libfranka protocol v10), its tool (the Franka Hand on 1338, or with `--tool vacuum`
# the vacuum gripper on 1339) and the control API: publish these. The
# 1 kHz robot state stream is UDP from the server to the port the client announced during the
# handshake, at the address the server sees the client at, and the client answers to wherever
# the states came from: it needs no EXPOSE and no publishing, and passes Docker's NAT. A client
# on the host connecting to the host's own address answers from the bridge's gateway instead;
# the server follows its answers there (docs/deployment.md). 443: the Desk (the robot's web API),
# served with `-e FRANKA_SIM_DESK_PORT=443` (docs/desk.md); off unless asked for, as outside.
# 8080: the web view (a browser's, plain HTTP and a WebSocket), served with
# `-e FRANKA_SIM_WEB_PORT=8080` (docs/viewing.md); the image carries the `web` extra.
EXPOSE 1337/tcp 1338/tcp 1339/tcp 1340/tcp 443/tcp 8080/tcp

# Ready once every robot the server serves answers /health on its control API. The server,
# however configured (flags or variables: --arm, --mobile-base, the control port, a token),
# writes what it serves to FRANKA_SIM_SERVING_FILE once every robot listens, and the check,
# given no address, reads it. Each check costs ~0.25 s of CPU.
HEALTHCHECK --interval=10s --timeout=5s --start-period=30s --retries=3 \
    CMD ["franka-sim", "check"]

# The process `franka-sim serve` starts is the server (its flags are checked in a child): as
# PID 1 it gets SIGTERM from `docker stop` and exits at once.
ENTRYPOINT ["franka-sim", "serve"]
