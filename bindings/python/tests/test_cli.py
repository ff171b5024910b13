# SPDX-License-Identifier: MIT
"""`python -m pkss` and the bundled C tools: JSON on stdout, clouds on
stdout and from stdin, -o read back bit-identically, exit codes."""
from __future__ import annotations

import io
import json
import subprocess
import sys

import numpy as np
import pytest

import pkss
from pkss import __main__ as cli, _tools
from conftest import REPO

PAIR = REPO / "tests" / "data"
SRC, TGT = PAIR / "airplane_0001_s.ply", PAIR / "airplane_0001_t.ply"
QUICK = ["--backend", "reference", "--points", "1500"]

needs_tools = pytest.mark.skipif(
    _tools.tool_path("pkss-align") is None,
    reason="the C tools are not bundled (a source checkout on PYTHONPATH): install the "
           "package (pip install ./bindings/python) to test python -m pkss")


def pkss_cli(*args, stdin=None):
    return subprocess.run([sys.executable, "-m", "pkss", *map(str, args)], input=stdin,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_usage_without_command():
    r = pkss_cli()
    assert r.returncode == 2 and b"usage: python -m pkss" in r.stderr
    r = pkss_cli("--help")
    assert r.returncode == 0 and b"align" in r.stdout
    r = pkss_cli("nonsense")
    assert r.returncode == 2 and b"unknown command" in r.stderr


def test_batch_dispatch(monkeypatch):
    import importlib.util

    if importlib.util.find_spec("pkss._batch_cli") is None:
        r = pkss_cli("batch")
        assert r.returncode == 2 and b"'batch' is not available" in r.stderr
    else:  # the batch module is present: main() dispatches to it
        calls = []
        mod = __import__("pkss._batch_cli", fromlist=["main"])
        monkeypatch.setattr(mod, "main", lambda argv: calls.append(argv) or 7)
        assert cli.main(["batch", "--x"]) == 7 and calls == [["--x"]]


@needs_tools
def test_align_json_schema(tmp_path):
    np.save(tmp_path / "src.npy", pkss.read_points(SRC))
    r = pkss_cli("align", tmp_path / "src.npy", TGT, "--json", "-", *QUICK)
    assert r.returncode == 0, r.stderr.decode()
    d = json.loads(r.stdout)
    assert d["schema_version"] == 1 and d["tool"] == "pkss-align"
    assert d["source"]["format"] == "npy" and d["source"]["points"] == 10001
    assert d["target"]["format"] == "ply"
    assert d["status"] == "PKSS_OK"
    assert d["parameters"]["backend"] == "reference"  # symbolic, as set
    assert d["parameters"]["points"] == 1500
    T = np.array(d["T_target_source"])
    assert T.shape == (4, 4) and abs(d["scale"] - 1.2492) < 0.01


@needs_tools
def test_align_output_cloud_bit_identical(tmp_path):
    # The same run twice (deterministic for a seed): PCD text and NPY doubles agree bit for bit.
    for ext in ("pcd", "npy"):
        r = pkss_cli("align", SRC, TGT, "-o", tmp_path / ("aligned." + ext), *QUICK)
        assert r.returncode == 0, r.stderr.decode()
    a = pkss.read_points(tmp_path / "aligned.pcd")
    b = pkss.read_points(tmp_path / "aligned.npy")
    assert a.shape == (10001, 3) and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@needs_tools
def test_align_stdin_and_stdout(tmp_path):
    r = pkss_cli("align", "-", TGT, "-o", "-", "--output-format", "xyz", *QUICK,
                 stdin=SRC.read_bytes())
    assert r.returncode == 0, r.stderr.decode()
    out = pkss.read_points(io.BytesIO(r.stdout), format="xyz")
    assert out.shape == (10001, 3)
    assert np.abs(out - pkss.read_points(TGT)).max() < 1e-3  # the pair corresponds 1:1


@needs_tools
def test_exit_codes(tmp_path):
    assert pkss_cli("align", SRC).returncode == 2  # usage
    r = pkss_cli("align", tmp_path / "missing.ply", TGT)
    assert r.returncode == 3 and b"PKSS_ERR_IO" in r.stderr
    (tmp_path / "bad.npy").write_bytes(b"\x93NUMPY\x01\x00\x10\x00{'descr': '<i4'")
    r = pkss_cli("align", tmp_path / "bad.npy", TGT)
    assert r.returncode == 4 and b"PKSS_ERR_FORMAT" in r.stderr
    assert pkss_cli("align", SRC, TGT, "-o", tmp_path / "x.obj").returncode == 2
    r = pkss_cli("info")
    assert r.returncode == 0 and b"pkss" in r.stdout


def test_help_shows_routes():
    import pydoc

    text = pydoc.render_doc(pkss, renderer=pydoc.plaintext)
    assert "read_points" in text and "python -m pkss" in text
    assert "npz" in pydoc.render_doc(pkss.read_points, renderer=pydoc.plaintext)
