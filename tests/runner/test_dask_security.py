"""Dask over TLS, loopback-only local clusters, plug-ins on workers, refused insecure addresses."""

from __future__ import annotations

import datetime
import ipaddress
import logging
from pathlib import Path

import pytest

from roman_sim.core.errors import ClusterError, ConfigError
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.runner.dask_executor import DaskExecutor, connect_client
from roman_sim.runner.dask_security import PluginImportError, check_address, is_loopback, security_for
from roman_sim.runner.executors import ExecutorConfig, TaskError
from roman_sim.testing import assert_same_run_folder as assert_same_folder

distributed = pytest.importorskip("distributed")
x509 = pytest.importorskip("cryptography.x509")


def _pem_pair(tmp: Path, name: str, issuer: tuple | None = None) -> tuple[Path, Path, object, object]:
    """A key and certificate (self-signed CA when ``issuer`` is None) as PEM files."""
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    ca_cert, ca_key = issuer if issuer else (None, key)
    now = datetime.datetime.now(datetime.UTC)
    b = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(ca_cert.subject if ca_cert else subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=1))
        .add_extension(x509.BasicConstraints(ca=issuer is None, path_length=None), critical=True)
    )
    if issuer:
        b = b.add_extension(
            x509.SubjectAlternativeName([x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
            False,
        )
    cert = b.sign(ca_key, hashes.SHA256())
    cert_path, key_path = tmp / f"{name}.pem", tmp / f"{name}.key"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    )
    return cert_path, key_path, cert, key


@pytest.fixture(scope="module")
def tls_cluster(tmp_path_factory):
    """A TLS LocalCluster on 127.0.0.1 (one worker), its CA and a client certificate signed by it."""
    from distributed import LocalCluster
    from distributed.security import Security

    d = tmp_path_factory.mktemp("certs")
    ca_pem, _, ca_cert, ca_key = _pem_pair(d, "ca")
    node_pem, node_key, _, _ = _pem_pair(d, "node", (ca_cert, ca_key))
    client_pem, client_key, _, _ = _pem_pair(d, "client", (ca_cert, ca_key))
    rogue_ca_pem, _, rogue_ca, rogue_ca_key = _pem_pair(d, "rogue_ca")
    rogue_pem, rogue_key, _, _ = _pem_pair(d, "rogue", (rogue_ca, rogue_ca_key))
    sec = Security(
        tls_ca_file=str(ca_pem),
        tls_scheduler_cert=str(node_pem),
        tls_scheduler_key=str(node_key),
        tls_worker_cert=str(node_pem),
        tls_worker_key=str(node_key),
        tls_client_cert=str(client_pem),
        tls_client_key=str(client_key),
        require_encryption=True,
    )
    cluster = LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        protocol="tls://",
        security=sec,
        dashboard_address=None,
    )
    yield {
        "address": cluster.scheduler_address,
        "ca": ca_pem,
        "cert": client_pem,
        "key": client_key,
        "rogue_cert": rogue_pem,
        "rogue_key": rogue_key,
        "rogue_ca": rogue_ca_pem,
    }
    cluster.close()


@pytest.mark.slow
def test_smoke_through_a_tls_cluster_gives_the_local_bytes(smoke_run, tls_cluster, tmp_path):
    assert tls_cluster["address"].startswith("tls://127.0.0.1:")
    ex = ExecutorConfig(
        kind="dask",
        scheduler_address=tls_cluster["address"],
        tls_ca_file=str(tls_cluster["ca"]),
        tls_cert=str(tls_cluster["cert"]),
        tls_key=str(tls_cluster["key"]),
    )
    res = Experiment(load_scenario("smoke"), tmp_path / "tls", executor=ex).run()
    assert res.timings.stages["evaluation"].pairs.executor == "dask"
    assert_same_folder(smoke_run.run_dir, res.run_dir)


def test_clients_without_the_certificate_are_refused(tls_cluster):
    from distributed.security import Security

    addr = tls_cluster["address"]
    with pytest.raises(ClusterError, match=f"Dask scheduler {addr}: cannot connect"):
        connect_client(addr, 5.0, None)  # no TLS at all
    rogue = Security(
        tls_ca_file=str(tls_cluster["ca"]),
        tls_client_cert=str(tls_cluster["rogue_cert"]),
        tls_client_key=str(tls_cluster["rogue_key"]),
        require_encryption=True,
    )
    with pytest.raises(ClusterError, match="cannot connect"):
        connect_client(addr, 5.0, rogue)  # a certificate the cluster's CA did not sign
    with pytest.raises(ConfigError, match="needs a CA and a client certificate"):
        DaskExecutor(ExecutorConfig(kind="dask", scheduler_address=addr))
    ok = connect_client(
        addr,
        10.0,
        security_for(
            ExecutorConfig(
                kind="dask",
                scheduler_address=addr,
                tls_ca_file=str(tls_cluster["ca"]),
                tls_cert=str(tls_cluster["cert"]),
                tls_key=str(tls_cluster["key"]),
            )
        ),
    )
    assert ok.submit(sum, [1, 2, 3]).result() == 6
    ok.close()


def test_a_refused_client_is_closed_before_the_error(tls_cluster):
    """A refused client's event loop is stopped at once, not left for the garbage collector.

    Left to the collector, its closing can run while the next client starts and holds the
    lock closing needs: a deadlock inside ``distributed``.
    """
    import gc
    import threading

    def loops() -> set[threading.Thread]:
        return {t for t in threading.enumerate() if t.name == "IO loop" and t.is_alive()}

    before = loops()
    gc.disable()  # only an explicit close may stop the loop here
    try:
        with pytest.raises(ClusterError, match="cannot connect"):
            connect_client(tls_cluster["address"], 5.0, None)
        assert loops() - before == set()
    finally:
        gc.enable()


def test_certificates_from_dask_config(tls_cluster):
    import dask

    with dask.config.set(
        {
            "distributed.comm.tls.ca-file": str(tls_cluster["ca"]),
            "distributed.comm.tls.client.cert": str(tls_cluster["cert"]),
            "distributed.comm.tls.client.key": str(tls_cluster["key"]),
        }
    ):
        sec = security_for(ExecutorConfig(kind="dask", scheduler_address=tls_cluster["address"]))
    assert sec.tls_ca_file == str(tls_cluster["ca"]) and sec.require_encryption


def test_addresses_not_on_loopback_need_tls_or_insecure(caplog):
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("127.0.0.9")
    assert not is_loopback("192.0.2.10") and not is_loopback("no-such-host.invalid")
    cfg = ExecutorConfig(kind="dask", scheduler_address="tcp://192.0.2.10:8786")
    with pytest.raises(ConfigError, match="unauthenticated .* --insecure"):
        check_address("tcp://192.0.2.10:8786", cfg, None)
    with caplog.at_level(logging.WARNING):
        assert (
            check_address("192.0.2.10:8786", cfg.model_copy(update={"insecure": True}), None) == "tcp://192.0.2.10:8786"
        )
    assert "unauthenticated" in caplog.text
    assert check_address("tcp://localhost:8786", cfg, None) == "tcp://localhost:8786"
    for bad in ("tcp://host", "http://127.0.0.1:8787", "tcp://127.0.0.1:0"):
        with pytest.raises(ConfigError, match="executor.scheduler_address"):
            check_address(bad, cfg, None)
    with pytest.raises(ConfigError, match="tls is set"):
        security_for(ExecutorConfig(kind="dask", scheduler_address="tcp://127.0.0.1:8786", tls=True))
    with pytest.raises(ConfigError, match="executor.tls_ca_file: no such file"):
        security_for(ExecutorConfig(kind="dask", scheduler_address="tls://127.0.0.1:8786", tls_ca_file="/nope.pem"))


def _http_host(dask_scheduler=None) -> str:
    return dask_scheduler.http_server.address


_DASHBOARD_PROBE = """
import json, sys, urllib.error, urllib.request
from roman_sim.runner.dask_executor import DaskExecutor
from roman_sim.runner.executors import ExecutorConfig, TaskError
def status(port):
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/status", timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as err:
        return err.code
if __name__ == "__main__":
    with DaskExecutor(ExecutorConfig(kind="dask", workers=1, dashboard=sys.argv[1] == "on")) as ex:
        info = ex.client.scheduler_info()
        host = ex.client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.http_server.address)
        print(json.dumps([host, status(info["services"]["dashboard"])]))
"""


def _dashboard(tmp_path, mode: str) -> list:
    """(HTTP host, status of /status) of a fresh local cluster, in a process of its own.

    Its own process: a dashboard another test started in this process leaves its pages
    registered in ``distributed``'s HTTP routes.
    """
    import json
    import os
    import subprocess
    import sys

    script = tmp_path / "dash_probe.py"
    script.write_text(_DASHBOARD_PROBE)
    out = subprocess.run(
        [sys.executable, str(script), mode],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
        check=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def _no_odd(x: int) -> int:
    if x % 2:
        raise ConfigError("no odd numbers")
    return x


def _w11_probe() -> str:
    import w11_uploaded_plugin

    return w11_uploaded_plugin.NAME


def test_local_cluster_is_loopback_only_and_plugins_must_be_importable_on_workers(tmp_path, monkeypatch):
    with DaskExecutor(ExecutorConfig(kind="dask", workers=1)) as ex:
        info = ex.client.scheduler_info()
        assert ex.address.startswith("tcp://127.0.0.1:")
        assert all(w.startswith("tcp://127.0.0.1:") for w in info["workers"])
        assert ex.client.run_on_scheduler(_http_host) == "127.0.0.1"  # health/metrics HTTP on loopback only
        with pytest.raises(TaskError, match=r"^task 1 failed on worker tcp://127\.0\.0\.1:\d+: no odd numbers$"):
            ex.map(_no_odd, [(0,), (1,), (2,)], ["task 0", "task 1", "task 2"])
        local = tmp_path / "local"
        local.mkdir()
        (local / "w11_probe_plugin.py").write_text("NAME = 'probe'\n")
        monkeypatch.syspath_prepend(str(local))  # importable here, not on the running worker
        with pytest.raises(
            PluginImportError,
            match=r"Dask worker tcp://127\.0\.0\.1:\d+ cannot import plug-in "
            r"module 'w11_probe_plugin'.*--upload w11_probe_plugin\.py",
        ):
            ex.check_imports(["w11_probe_plugin"])
    shipped = tmp_path / "shipped" / "w11_uploaded_plugin.py"
    shipped.parent.mkdir()
    shipped.write_text("NAME = 'uploaded aligner'\n")
    with DaskExecutor(ExecutorConfig(kind="dask", workers=1, upload=[str(shipped)], tls=True)) as ex:
        assert ex.address.startswith("tls://127.0.0.1:")
        ex.check_imports(["w11_uploaded_plugin"])
        assert ex.map(_w11_probe, [()], ["probe"]) == ["uploaded aligner"]
    assert _dashboard(tmp_path, "off") == ["127.0.0.1", 404]  # no dashboard pages unless asked for
    assert _dashboard(tmp_path, "on") == ["127.0.0.1", 200]
    with pytest.raises(ConfigError, match="executor.upload"):
        DaskExecutor(ExecutorConfig(kind="dask", workers=1, upload=[str(tmp_path / "missing.py")]))


def test_cli_refuses_insecure_and_incomplete_cluster_options_in_one_line(tmp_path):
    from typer.testing import CliRunner

    from roman_sim.cli import app

    cases = [
        (["--scheduler", "tcp://192.0.2.10:8786"], "unauthenticated"),
        (["--scheduler", "tls://127.0.0.1:1", "--tls-ca-file", str(tmp_path / "nope.pem")], "tls_ca_file"),
        (["--scheduler", "tls://127.0.0.1:1"], "needs a CA and a client certificate"),
        (["--executor", "dask", "--upload", str(tmp_path / "x.txt")], "executor.upload"),
        (["--executor", "cluster"], "executor: kind: Input should be"),
    ]
    for opts, msg in cases:
        res = CliRunner().invoke(app, ["run", "smoke", "--out", str(tmp_path / "run"), *opts])
        assert res.exit_code == 1, (opts, res.output)
        assert msg in res.output and "Traceback" not in res.output, (opts, res.output)
        assert not (tmp_path / "run" / "maps").exists()
