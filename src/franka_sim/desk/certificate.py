"""The Desk's TLS certificate: the user's own (`--desk-cert`/`--desk-key`), or a self-signed
one made at the first start and kept per user, as a robot keeps the one it made.

Kept in `$XDG_DATA_HOME/franka-sim/desk` (else `~/.local/share/franka-sim/desk`): the key
readable by its owner only. Made with the `openssl` command when there is one (most systems),
else with the `cryptography` package (`pip install franka-sim[desk]`); neither is needed with
a certificate of one's own. Simulators starting at once make it once (a lock file).
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

SUBJECT = "franka-sim Desk"
# The name Desk clients that verify the robot's certificate give its TLS (panda-python's Pilot
# events), whatever address they connect to: a client that trusts this certificate gets on.
ROBOT_NAME = "robot.franka.de"
DAYS = 3650


class CertificateError(OSError):
    """No certificate could be made or read: says why and what to do."""


def store() -> Path:
    base = os.environ.get("XDG_DATA_HOME")
    root = Path(base) if base and os.path.isabs(base) else Path.home() / ".local" / "share"
    return root / "franka-sim" / "desk"


def kept_certificate(directory: Path | None = None) -> tuple[Path, Path]:
    """(certificate, key) from the store, made there first if it has none."""
    directory = directory or store()
    cert, key = directory / "cert.pem", directory / "key.pem"
    try:
        directory.mkdir(parents=True, exist_ok=True, mode=0o700)
        with open(directory / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not (cert.exists() and key.exists()):
                _make(directory, cert, key)
    except OSError as exc:
        raise CertificateError(f"cannot keep the Desk's certificate in {directory}: "
                               f"{exc.strerror or exc} (or give --desk-cert/--desk-key)") from None
    return cert, key


def _make(directory: Path, cert: Path, key: Path) -> None:
    with tempfile.TemporaryDirectory(dir=directory) as work:
        new_cert, new_key = Path(work) / "cert.pem", Path(work) / "key.pem"
        if shutil.which("openssl"):
            _with_openssl(new_cert, new_key)
        else:
            _with_cryptography(new_cert, new_key)
        os.chmod(new_key, 0o600)
        os.replace(new_key, key)
        os.replace(new_cert, cert)


def _with_openssl(cert: Path, key: Path) -> None:
    command = ["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt",
               "ec_paramgen_curve:prime256v1", "-nodes", "-keyout", str(key), "-out", str(cert),
               "-days", str(DAYS), "-subj", f"/CN={SUBJECT}",
               "-addext", f"subjectAltName=DNS:localhost,DNS:{ROBOT_NAME},IP:127.0.0.1"]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise CertificateError(f"openssl could not make the Desk's certificate: {last}")


def _with_cryptography(cert: Path, key: Path) -> None:
    try:
        import datetime
        import ipaddress

        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import NameOID
    except ImportError:
        raise CertificateError(
            "the Desk needs a TLS certificate: no `openssl` command to make one, and no "
            "`cryptography` package (pip install 'franka-sim[desk]'), or give "
            "--desk-cert/--desk-key") from None
    private = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, SUBJECT)])
    now = datetime.datetime.now(datetime.timezone.utc)
    certificate = (
        x509.CertificateBuilder().subject_name(name).issuer_name(name)
        .public_key(private.public_key()).serial_number(x509.random_serial_number())
        .not_valid_before(now).not_valid_after(now + datetime.timedelta(days=DAYS))
        .add_extension(x509.SubjectAlternativeName([
            x509.DNSName("localhost"), x509.DNSName(ROBOT_NAME),
            x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
            critical=False)
        .sign(private, hashes.SHA256()))
    key.write_bytes(private.private_bytes(serialization.Encoding.PEM,
                                          serialization.PrivateFormat.PKCS8,
                                          serialization.NoEncryption()))
    cert.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))


def server_context(cert: Path, key: Path, kept: bool = False):
    """The TLS context the Desk serves with (CertificateError: unreadable or not a pair;
    `kept`: the store's, which a new one replaces once it is deleted). A handshake it refuses
    (a client speaking plain HTTP, garbage) is one log line: the event loop drops that
    connection without a word."""
    import logging
    import ssl

    log = logging.getLogger(__name__)

    class LoggedHandshake(ssl.SSLObject):
        def do_handshake(self) -> None:
            try:
                super().do_handshake()
            except (ssl.SSLWantReadError, ssl.SSLWantWriteError):
                raise
            except ssl.SSLError as exc:
                log.warning("Desk: TLS handshake refused (%s): that connection is closed",
                            exc.reason or exc)
                raise

    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.sslobject_class = LoggedHandshake
    try:
        context.load_cert_chain(cert, key)
    except (OSError, ssl.SSLError) as exc:
        fix = (f"; delete {cert.parent} to have a new one made" if kept
               else " (--desk-cert/--desk-key)")
        raise CertificateError(f"cannot serve the Desk with {cert} and {key}: "
                               f"{_why(exc)}{fix}") from None
    return context


def _why(exc: OSError) -> str:
    """What OpenSSL's terse reasons mean for a certificate and key given as files."""
    import ssl

    if not isinstance(exc, ssl.SSLError):
        return exc.strerror or str(exc)
    reason = exc.reason or ""
    if reason == "KEY_VALUES_MISMATCH":
        return "the key is not the certificate's"
    if reason in ("PEM_LIB", "NO_START_LINE") or "PEM lib" in str(exc):
        return "not a PEM certificate and its PEM private key"
    return f"OpenSSL refused them ({reason or exc})"
