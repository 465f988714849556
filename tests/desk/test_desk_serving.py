"""Serving the Desk: its flags checked on one line, its certificate made once and kept per user
(or one's own), the users' passwords kept off the command line, and nothing of it (TLS
included) in a server without a Desk."""

from __future__ import annotations

import importlib.util
import os
import shutil
import socket
import ssl
import subprocess
import sys
from pathlib import Path

import pytest

from franka_sim.desk import certificate
from franka_sim.testing import fresh_loopback_address, running_sim

PORT = 8443


@pytest.mark.parametrize("args, reason", [
    (["--desk-user", "nobody"], "expected NAME:PASSWORD"),
    (["--desk-boot", "sideways"], "one of ready, locked"),
    (["--desk-port", "1338"], "another service's port"),
    (["--desk-boot", "locked"], "give --desk-port too"),
    (["--desk-cert", __file__, "--desk-key", __file__], "the certificate is the Desk's"),
])
def test_bad_desk_flags_are_refused_on_one_line(args, reason):
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), *args], capture_output=True, text=True,
                          env={**os.environ, "COLUMNS": "200"}, timeout=60)
    assert done.returncode != 0
    assert reason in done.stderr and "Traceback" not in done.stderr


def _serve(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), *args], capture_output=True, text=True,
                          timeout=60, env={**os.environ, "COLUMNS": "200", **(env or {})})


def test_a_certificate_needs_its_key_and_a_key_its_certificate(tmp_path):
    cert, key = certificate.kept_certificate(tmp_path)
    done = _serve("--desk-port", str(PORT), "--desk-cert", str(cert))
    assert done.returncode == 2 and "--desk-cert" in done.stderr  # (a command line refused)
    assert "give --desk-key too" in done.stderr
    done = _serve("--desk-port", str(PORT), "--desk-key", str(key))
    assert done.returncode == 2 and "--desk-key: " in done.stderr
    assert "give --desk-cert too" in done.stderr


def test_a_pair_that_is_not_one_is_refused_saying_why(tmp_path):
    """Not PEM, or another certificate's key: one line each, and how to mend it (a kept
    certificate: delete it)."""
    cert, key = certificate.kept_certificate(tmp_path / "one")
    _, other_key = certificate.kept_certificate(tmp_path / "two")
    garbage = tmp_path / "garbage.pem"
    garbage.write_text("not a certificate")
    for pair, reason in [((garbage, key), "not a PEM certificate and its PEM private key"),
                         ((cert, other_key), "the key is not the certificate's")]:
        done = _serve("--desk-port", str(PORT), "--desk-cert", str(pair[0]),
                      "--desk-key", str(pair[1]))
        assert done.returncode == 1 and reason in done.stderr, done.stderr
        assert "PEM lib" not in done.stderr and "Traceback" not in done.stderr
    data = tmp_path / "data"
    kept, _ = certificate.kept_certificate(data / "franka-sim" / "desk")
    kept.write_text("damaged")
    done = _serve("--desk-port", str(PORT), env={"XDG_DATA_HOME": str(data)})
    assert done.returncode == 1 and f"delete {kept.parent}" in done.stderr, done.stderr


def test_the_certificate_is_made_once_and_kept(tmp_path):
    env = {"XDG_DATA_HOME": str(tmp_path)}
    served = []
    for _ in range(2):
        with running_sim("--desk-port", str(PORT), env=env) as sim:
            served.append(ssl.get_server_certificate((sim.host, PORT)))
    kept = tmp_path / "franka-sim" / "desk"
    assert served[0] == served[1] == (kept / "cert.pem").read_text()
    assert (kept / "key.pem").stat().st_mode & 0o077 == 0


@pytest.mark.parametrize("maker", ["openssl", "cryptography"])
def test_a_client_that_trusts_the_certificate_verifies_it_as_the_robots(tmp_path, maker,
                                                                       monkeypatch):
    """panda-python's forced take listens for the Pilot over TLS verified against the name
    robot.franka.de: a client given the kept certificate as its trust gets on, under that name
    as under localhost."""
    if maker == "cryptography":
        pytest.importorskip("cryptography")
        monkeypatch.setattr(shutil, "which", lambda name: None)
    cert, key = certificate.kept_certificate(tmp_path)
    with running_sim("--desk-port", str(PORT), "--desk-cert", str(cert),
                     "--desk-key", str(key)) as sim:
        for name in ("robot.franka.de", "localhost"):
            trusting = ssl.create_default_context(cafile=str(cert))
            with socket.create_connection((sim.host, PORT), timeout=20) as raw:
                with trusting.wrap_socket(raw, server_hostname=name) as tls:
                    assert tls.version() is not None


def test_ones_own_certificate_is_served(tmp_path):
    cert, key = certificate.kept_certificate(tmp_path / "own")
    with running_sim("--desk-port", str(PORT), "--desk-cert", str(cert), "--desk-key", str(key),
                     "--desk-user", "lab:very-secret",
                     env={"XDG_DATA_HOME": str(tmp_path / "data")}) as sim:
        assert ssl.get_server_certificate((sim.host, PORT)) == cert.read_text()
        assert not (tmp_path / "data" / "franka-sim").exists()
        cmdline = Path(f"/proc/{sim.proc.pid}/cmdline").read_bytes()
        assert b"very-secret" not in cmdline and b"--desk-user\0***" in cmdline
        maps = Path(f"/proc/{sim.proc.pid}/maps").read_text()
        assert "_ssl." in maps  # the Desk keeps TLS; without it the process has none


def test_without_openssl_the_certificate_needs_cryptography(tmp_path, monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    if importlib.util.find_spec("cryptography") is not None:
        cert, key = certificate.kept_certificate(tmp_path)
        assert "BEGIN CERTIFICATE" in cert.read_text()
        certificate.server_context(cert, key)
    else:
        with pytest.raises(certificate.CertificateError, match=r"franka-sim\[desk\]"):
            certificate.kept_certificate(tmp_path)
        assert not (tmp_path / "cert.pem").exists()


def test_a_simulator_without_a_desk_imports_none_of_it():
    program = (
        "import sys\n"
        "from franka_sim import FrankaSim\n"
        "sim = FrankaSim(host='127.0.0.1')\n"
        "print(sorted(m for m in sys.modules if '.desk' in m))\n"
        "print(sim.control.desk()['arm_ready'], sim.core.robot_mode.name)\n")
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == ["[]", "True kIdle"]
