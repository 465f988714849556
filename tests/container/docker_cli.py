"""The docker client, aimed at one daemon, and the failure every step of the self-test raises.

Each call names its step, so a failure reads "container test: build failed: ..." wherever it
happened. The client gets a configuration directory of its own: no credential helper or
context of the user's is consulted, and the classic builder is asked for (BuildKit would
fetch its frontend image, and the builds here have no network). It runs under the normal
scheduling policy: a test process that made a pylibfranka.Robot is SCHED_FIFO 99 (libfranka
raises the thread it is made in), and Go programs under that spin on a 2-core machine.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path


# `chrt --other 0 COMMAND`: COMMAND under SCHED_OTHER, whatever its caller's policy.
NORMAL_POLICY = ("chrt", "--other", "0") if shutil.which("chrt") else ()


class StepFailed(Exception):
    def __init__(self, step: str, why: str) -> None:
        super().__init__(f"{step} failed: {why}")
        self.step = step
        self.why = why


def last_line(text: str, prefer: tuple[str, ...] = ("error", "failed", "denied")) -> str:
    """The line that says most about a failure: the last one naming an error, else the last."""
    boxes = {code: None for code in range(0x2500, 0x2580)}  # a CLI's framed error message
    lines = [line.translate(boxes).strip() for line in text.splitlines()]
    lines = [line for line in lines if line and line.lower() != "error"]
    for line in reversed(lines):
        if any(word in line.lower() for word in prefer):
            return line
    return lines[-1] if lines else "(no output)"


class Docker:
    """`docker -H URL ...` with a private configuration directory under `work`."""

    def __init__(self, url: str, work: Path) -> None:
        self.url = url
        binary = shutil.which("docker")
        if binary is None:
            raise StepFailed("daemon", "the docker client is not installed (Debian: docker.io)")
        self.binary = binary
        config = work / "docker-config"
        config.mkdir(parents=True, exist_ok=True)
        self.env = {**os.environ, "DOCKER_CONFIG": str(config), "DOCKER_BUILDKIT": "0",
                    "DOCKER_CLI_HINTS": "false"}
        self.env.pop("DOCKER_HOST", None)
        self.env.pop("DOCKER_CONTEXT", None)

    def run(self, step: str, *args: str, timeout: float = 60.0, check: bool = True,
            log: Path | None = None) -> subprocess.CompletedProcess:
        """Run one docker command; with `log`, its output goes to that file (and is read back)."""
        command = [*NORMAL_POLICY, self.binary, "-H", self.url, *args]
        try:
            if log is None:
                done = subprocess.run(command, capture_output=True, text=True, env=self.env,
                                      timeout=timeout, stdin=subprocess.DEVNULL)
            else:
                with open(log, "w") as out:
                    done = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT,
                                          text=True, env=self.env, timeout=timeout,
                                          stdin=subprocess.DEVNULL)
                done.stdout, done.stderr = "", log.read_text(errors="replace")
        except subprocess.TimeoutExpired:
            why = f"`docker {args[0]}` did not finish in {timeout:.0f} s"
            raise StepFailed(step, why) from None
        if check and done.returncode != 0:
            raise StepFailed(step, f"`docker {args[0]}`: {last_line(done.stderr + done.stdout)}")
        return done

    def reachable(self) -> str | None:
        """None when the daemon answers, else why not."""
        done = self.run("daemon", "version", "--format", "{{.Server.Version}}", timeout=20,
                        check=False)
        if done.returncode == 0:
            return None
        return last_line(done.stderr + done.stdout)

    def image_exists(self, name: str) -> bool:
        return self.run("base", "image", "inspect", name, check=False).returncode == 0

    def inspect(self, step: str, name: str, template: str) -> str:
        return self.run(step, "inspect", "--format", template, name).stdout.strip()
