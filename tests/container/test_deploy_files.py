"""The deployment files, checked offline: the Kubernetes manifests against the API's schemas
(kubernetes-validate ships them) and for what the schemas cannot see (names that must agree,
probes, resources); the compose file and the Dockerfile for what docs/deployment.md promises."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parents[2]
KUBERNETES = ROOT / "deploy" / "kubernetes"
FCI, HAND, VACUUM, CONTROL, DESK, WEB = 1337, 1338, 1339, 1340, 443, 8080


def _manifests() -> list[dict]:
    kustomization = yaml.safe_load((KUBERNETES / "kustomization.yaml").read_text())
    return [doc for name in kustomization["resources"]
            for doc in yaml.safe_load_all((KUBERNETES / name).read_text()) if doc]


def _one(kind: str) -> dict:
    found = [doc for doc in _manifests() if doc["kind"] == kind]
    assert len(found) == 1, f"{len(found)} {kind}s"
    return found[0]


@pytest.mark.parametrize("version", ["1.28.0", "1.33.0"])
def test_the_manifests_match_the_kubernetes_schemas_strictly(version):
    kubernetes_validate = pytest.importorskip("kubernetes_validate")
    for doc in _manifests():
        kubernetes_validate.validate(doc, version, strict=True)  # raises on any unknown field


def test_the_kustomization_lists_every_manifest_and_names_the_image():
    kustomization = yaml.safe_load((KUBERNETES / "kustomization.yaml").read_text())
    assert kustomization["kind"] == "Kustomization"
    listed = set(kustomization["resources"])
    assert listed == {p.name for p in KUBERNETES.glob("*.yaml")} - {"kustomization.yaml"}
    container = _one("StatefulSet")["spec"]["template"]["spec"]["containers"][0]
    assert container["image"].split(":")[0] in {i["name"] for i in kustomization["images"]}


def test_each_robot_has_a_stable_name_through_a_headless_service():
    service, robots = _one("Service"), _one("StatefulSet")
    assert service["spec"]["clusterIP"] == "None"  # per-pod DNS records, no NAT in between
    assert robots["spec"]["serviceName"] == service["metadata"]["name"] == "franka-sim"
    assert robots["metadata"]["name"] == "franka-sim"  # pods franka-sim-0, franka-sim-1, ...
    labels = robots["spec"]["template"]["metadata"]["labels"]
    assert robots["spec"]["selector"]["matchLabels"].items() <= labels.items()
    assert service["spec"]["selector"].items() <= labels.items()
    ports = {(p["port"], p.get("protocol", "TCP")) for p in service["spec"]["ports"]}
    assert ports == {(FCI, "TCP"), (HAND, "TCP"), (CONTROL, "TCP"), (WEB, "TCP")}


def test_robots_are_probed_with_franka_sim_check_and_sized_by_measurement():
    pod = _one("StatefulSet")["spec"]["template"]["spec"]
    container = pod["containers"][0]
    for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
        # no address: every robot the serving file lists, however `args` configure them
        assert container[probe]["exec"]["command"] == ["franka-sim", "check"]
    # the serving file's folder is writable under a read-only root
    assert container["securityContext"]["readOnlyRootFilesystem"] is True
    mounts = {m["mountPath"]: m["name"] for m in container["volumeMounts"]}
    serving_file = _image_env()["FRANKA_SIM_SERVING_FILE"]
    assert str(Path(serving_file).parent) in mounts
    assert mounts[str(Path(serving_file).parent)] in {v["name"] for v in pod["volumes"]}
    resources = container["resources"]
    assert {"cpu", "memory"} <= resources["requests"].keys()
    assert "cpu" not in resources.get("limits", {})  # CFS throttling would stall the stream
    assert "memory" in resources["limits"]
    assert pod["securityContext"]["runAsNonRoot"] is True
    assert pod["securityContext"]["runAsUser"] == _dockerfile_user()


def _dockerfile() -> str:
    return (ROOT / "Dockerfile").read_text()


def _image_env() -> dict[str, str]:
    pairs = shlex.split(" ".join(_instructions("ENV")))
    return dict(pair.split("=", 1) for pair in pairs)


def _instructions(keyword: str) -> list[str]:
    text = re.sub(r"\\\n", " ", _dockerfile())
    return [line.split(None, 1)[1] for line in text.splitlines()
            if line.split(None, 1)[:1] == [keyword]]


def _dockerfile_user() -> int:
    (user,) = _instructions("USER")
    return int(user.split(":")[0])


def test_the_dockerfile_builds_from_any_base_into_a_non_root_runtime():
    assert _instructions("ARG")[0] == "BASE_IMAGE=python:3.11-slim"
    froms = _instructions("FROM")
    assert len(froms) == 2 and all(f.startswith("${BASE_IMAGE}") for f in froms)
    assert _dockerfile_user() != 0
    assert _instructions("ENTRYPOINT") == ['["franka-sim", "serve"]']
    assert "FRANKA_SIM_HOST=0.0.0.0" in " ".join(_instructions("ENV"))
    assert _instructions("EXPOSE") == [
        f"{FCI}/tcp {HAND}/tcp {VACUUM}/tcp {CONTROL}/tcp {DESK}/tcp {WEB}/tcp"]
    # the image serves the web view, and records
    (extras,) = [a.split("=", 1)[1] for a in _instructions("ARG") if a.startswith("EXTRAS=")]
    assert set(extras.split(",")) == {"web", "record"}
    assert '"$wheel${EXTRAS:+[$EXTRAS]}"' in _dockerfile()
    # the check takes what it asks from the file the server writes, not from `serve`'s flags
    assert _image_env()["FRANKA_SIM_SERVING_FILE"].startswith("/tmp/")
    (healthcheck,) = _instructions("HEALTHCHECK")
    assert healthcheck.endswith('CMD ["franka-sim", "check"]')
    assert "--no-index --find-links" in _dockerfile()  # offline from a wheelhouse


def test_the_build_context_holds_what_the_wheel_is_built_from():
    ignored = (ROOT / ".dockerignore").read_text().splitlines()
    kept = {line[1:].rstrip("/") for line in ignored if line.startswith("!")}
    assert {"pyproject.toml", "README.md", "src", "urdf", "wheelhouse", "examples"} <= kept


def _compose() -> dict:
    return yaml.safe_load((ROOT / "deploy" / "compose.yaml").read_text())


def test_compose_puts_two_robots_and_a_client_on_one_network_without_published_ports():
    compose = _compose()
    services = compose["services"]
    robots = [name for name, s in services.items() if s.get("image", "").startswith("franka-sim")]
    assert len(robots) == 2
    (network,) = compose["networks"]
    for name, service in services.items():
        assert service["networks"] == [network], name
        assert "network_mode" not in service, name
        # No NAT for the robot's ports: only the web view's (plain TCP) may be published.
        for published in service.get("ports", []):
            assert published.endswith(f":{WEB}"), (name, published)
            assert service["environment"]["FRANKA_SIM_WEB_PORT"] == str(WEB)
    client = services["client"]
    assert {r: {"condition": "service_healthy"} for r in robots} == client["depends_on"]
    command = " ".join(client["command"])
    assert all(robot in command for robot in robots)
    (example,) = re.findall(r"examples/\S+\.py", command)
    assert (ROOT / example).exists()


def test_compose_builds_from_files_that_exist():
    for name, service in _compose()["services"].items():
        build = service.get("build")
        if build:
            context = (ROOT / "deploy" / build["context"]).resolve()
            assert (context / build["dockerfile"]).exists(), name


def test_the_client_dockerfile_installs_the_tested_pylibfranka():
    text = (ROOT / "deploy" / "client.Dockerfile").read_text()
    pins = [r for r in shlex.split(ROOT.joinpath("pyproject.toml").read_text().split("test = [")[1]
                                   .split("]")[0].replace(",", " ")) if "pylibfranka" in r]
    assert pins and pins[0] in text
