"""The base image, made from Debian's packages: no container registry is needed.

`debootstrap --variant=minbase --include=python3,python3-venv,libpython3.11-dev bookworm` (the
headers: as in python:3.11-slim, the build stage compiles the cycle's kernels) from the Debian mirror
apt is configured with, trimmed of apt's caches, the docs and the translations, packed as a
tarball and imported. The tarball is kept in a cache folder, one per ISO week (so security
updates come in weekly) and recipe: a cold start costs ~45 s, a warm one the import (~3 s).
"""

from __future__ import annotations

import datetime
import hashlib
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from docker_cli import Docker, StepFailed, last_line

SUITE = "bookworm"  # its python3 is 3.11, the project's version
PACKAGES = "python3,python3-venv,libpython3.11-dev"
TRIMMED = ("var/cache/apt/archives", "var/lib/apt/lists", "usr/share/doc", "usr/share/man",
           "usr/share/info", "usr/share/locale")  # the folders' contents go
KEPT = {"locale.alias"}
RECIPE = hashlib.sha256(repr((SUITE, PACKAGES, TRIMMED, KEPT)).encode()).hexdigest()[:8]


def default_cache() -> Path:
    if os.environ.get("FRANKA_SIM_CONTAINER_CACHE"):
        return Path(os.environ["FRANKA_SIM_CONTAINER_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "franka-sim"


def base_image(docker: Docker, name: str, cache: Path) -> str:
    """`name`, imported from the cached tarball (made first if this week has none)."""
    tarball = cached_rootfs(cache)
    docker.run("base", "import", str(tarball), name, timeout=300)
    return name


def cached_rootfs(cache: Path) -> Path:
    year, week, _ = datetime.date.today().isocalendar()
    tarball = cache / f"python-base-{SUITE}-{RECIPE}-{year}w{week:02d}.tar"
    if tarball.exists():
        return tarball
    cache.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache, prefix="debootstrap-") as scratch:
        rootfs = Path(scratch) / "rootfs"
        _debootstrap(rootfs)
        for folder in TRIMMED:
            for entry in (rootfs / folder).glob("*"):
                if entry.name in KEPT:
                    continue
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
        partial = Path(scratch) / "rootfs.tar"
        packed = subprocess.run(["tar", "--numeric-owner", "-C", str(rootfs), "-cf", str(partial),
                                 "."], capture_output=True, text=True)
        if packed.returncode != 0:
            raise StepFailed("base", f"tar of the root file system: {last_line(packed.stderr)}")
        os.replace(partial, tarball)  # whole or absent, should two runs race
    for old in cache.glob(f"python-base-{SUITE}-*.tar"):
        if old != tarball:
            old.unlink(missing_ok=True)
    return tarball


def _debootstrap(rootfs: Path) -> None:
    if shutil.which("debootstrap") is None:
        raise StepFailed("base", "debootstrap is not installed (Debian: debootstrap)")
    mirror = apt_mirror(SUITE)
    command = ["debootstrap", "--variant=minbase", f"--include={PACKAGES}", SUITE, str(rootfs),
               mirror]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=600,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        raise StepFailed("base", f"debootstrap from {mirror} took over 10 minutes") from None
    if done.returncode != 0:
        log = rootfs / "debootstrap" / "debootstrap.log"
        detail = log.read_text(errors="replace") if log.exists() else done.stderr + done.stdout
        raise StepFailed("base", f"debootstrap from {mirror}: {last_line(detail)}")


def apt_mirror(suite: str, etc: Path = Path("/etc/apt")) -> str:
    """The URI apt fetches `suite`'s main component from (deb822 .sources or one-line .list)."""
    sources = sorted(etc.glob("sources.list.d/*.sources"))
    for path in sources:
        for paragraph in re.split(r"\n\s*\n", path.read_text()):
            fields = dict(re.findall(r"^([A-Za-z-]+):[ \t]*(.*)$", paragraph, flags=re.M))
            if ("deb" in fields.get("Types", "").split()
                    and suite in fields.get("Suites", "").split()
                    and fields.get("Enabled", "yes").lower() != "no"):
                return fields["URIs"].split()[0]
    for path in [etc / "sources.list", *sorted(etc.glob("sources.list.d/*.list"))]:
        if not path.exists():
            continue
        for line in path.read_text().splitlines():
            words = re.sub(r"\[[^]]*\]", "", line.split("#")[0]).split()
            if len(words) >= 3 and words[0] == "deb" and words[2] == suite:
                return words[1]
    raise StepFailed("base", f"apt has no Debian mirror for {suite} in {etc}/sources.list*")
