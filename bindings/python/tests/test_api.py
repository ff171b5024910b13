# SPDX-License-Identifier: MIT
"""The binding's contract: cdef vs header, version, parameters, input
validation, errors, lifetimes, devices, documentation. Fast: small clouds."""
from __future__ import annotations

import ast
import dataclasses
import gc
import importlib.resources
import inspect
import pickle
import pydoc
import re
import weakref

import numpy as np
import pytest

import pkss
from pkss import _build, _lib

from conftest import FAST, HEADER, LibSpy, apply, random_similarity, shape


# ------------------------------------------------------------ cdef / version
def test_bundled_cdef_matches_header(header_text):
    path = importlib.resources.files("pkss").joinpath(_build.CDEF_FILE)
    if not path.is_file():
        pytest.skip("not an installed package: the cdef was built from the header at import")
    bundled = path.read_text("utf-8")
    assert bundled == _build.cdef_for(HEADER.parent), (
        "the cdef bundled in the installed package differs from include/pkss.h: "
        "reinstall with `pip install ./bindings/python`")


def test_bundled_ffi_matches_header(header_text):
    import cffi

    fresh = cffi.FFI()
    fresh.cdef(_build.cdef_for(HEADER.parent))
    for t in ("pkss_result", "pkss_candidate", "pkss_counts", "pkss_timings",
              "pkss_device_desc"):
        assert _lib.ffi.sizeof(t) == fresh.sizeof(t), t
        assert _lib.ffi.offsetof(t, "%s" % fresh.typeof(t).fields[-1][0]) == \
            fresh.offsetof(t, fresh.typeof(t).fields[-1][0])
    for e in ("pkss_status", "pkss_param", "pkss_switch", "pkss_backend", "pkss_rotation_set"):
        assert _lib.ffi.typeof(e).relements == fresh.typeof(e).relements, e


def test_cdef_extraction_strips_export_token(header_text):
    cdef = _build.extract_cdef(header_text)
    assert "PKSS_API" not in cdef
    assert "pkss_register(" in cdef
    assert "#define PKSS_VERSION_MAJOR" in cdef
    with pytest.raises(ValueError, match="PKSS_CDEF_BEGIN"):
        _build.extract_cdef("int x;")


def test_version(header_text):
    assert pkss.__version__ == _build.version_from_header(header_text)
    assert pkss.library_version.split(".")[0] == pkss.__version__.split(".")[0]
    assert re.match(r"^\d+\.\d+\.\d+$", pkss.__version__)
    assert pkss.build_info().startswith("pkss ")
    assert pkss.MAX_CANDIDATES == 32


def test_major_version_mismatch_is_an_import_error():
    _lib.check_version(_lib.lib.PKSS_VERSION_NUMBER, _lib.lib.PKSS_VERSION_MAJOR)
    _lib.check_version(_lib.lib.PKSS_VERSION_MAJOR * 10000 + 9999, _lib.lib.PKSS_VERSION_MAJOR)
    with pytest.raises(ImportError, match="major version"):
        _lib.check_version((_lib.lib.PKSS_VERSION_MAJOR + 1) * 10000, _lib.lib.PKSS_VERSION_MAJOR)


def test_library_is_found():
    assert pkss.library_path
    cands = _lib._candidates()
    assert cands and cands[0][1] == pkss.library_path


# ---------------------------------------------------------------- parameters
def _c_param_names():
    ffi, lib = _lib.ffi, _lib.lib
    return [ffi.string(lib.pkss_param_name(v)).decode()
            for v in sorted(ffi.typeof("pkss_param").elements)]


def test_param_names_are_the_c_names():
    assert list(pkss.PARAM_NAMES) == _c_param_names()


def _keyword_params(func, skip):
    sig = inspect.signature(func)
    return [(p.name, p.kind, p.default, p.annotation)
            for p in list(sig.parameters.values())[skip:]]


def test_argspec_defaults_agree():
    """register(), Context() and Context.set() take the same keywords with
    the same defaults (soundfile's test_argspec)."""
    f = _keyword_params(pkss.register, 2)
    assert f[-1][:3] == ("progress", inspect.Parameter.KEYWORD_ONLY, None)
    f = f[:-1]  # progress is per call: not a parameter of Context()/set()
    assert [p[0] for p in f] == list(pkss.PARAM_NAMES)
    assert all(p[1] == inspect.Parameter.KEYWORD_ONLY and p[2] is None for p in f)
    assert _keyword_params(pkss.Context.__init__, 1) == f
    assert _keyword_params(pkss.Context.set, 1) == f
    assert list(inspect.signature(pkss.register).parameters)[:2] == ["source", "target"]
    assert list(inspect.signature(pkss.Context.register).parameters)[1:] == [
        "source", "target", "progress"]


def test_defaults_come_from_the_library():
    with pkss.Context() as ctx:
        params = ctx.params
    assert params == pkss.default_params()
    for name, value in params.items():
        try:
            lo, hi, default = pkss.param_bounds(name)
        except ValueError:
            continue
        assert value == default, name
        assert lo <= default <= hi


def _doc_entries(doc):
    """name -> (type, description) of every numpydoc entry ``name : type``."""
    out = {}
    for m in re.finditer(r"^( +)(\w+) : ([^\n]*)\n((?:\1    [^\n]*\n)+)", doc, re.M):
        out[m.group(2)] = (m.group(3), " ".join(m.group(4).split()))
    return out


def _names_in_braces(type_line):
    m = re.search(r"\{([^}]*)\}", type_line)
    return tuple(ast.literal_eval("(%s,)" % m.group(1))) if m else ()


@pytest.mark.parametrize("obj", [pkss.register, pkss.Context, pkss.Context.set],
                         ids=["register", "Context", "Context.set"])
def test_docstrings_match_the_parameter_table(obj):
    """Issue #20: every documented parameter matches pkss_param_at() --
    names in order, types and value names, defaults, ranges, constraints,
    units and the one-line doc. The docs are generated from the table; this
    parses them back independently so neither can drift."""
    if obj.__doc__ is None:
        pytest.skip("docstrings stripped (python -OO)")
    entries = _doc_entries(obj.__doc__)
    entries.pop("progress", None)  # per call, not a library parameter
    assert list(entries) == [p.name for p in pkss.parameters()]
    for p in pkss.parameters():
        type_line, text = entries[p.name]
        assert " ".join(p.doc.split()) in text, p.name
        m = re.search(r"Default (.+?)[;.](?:\s|$)", text)
        assert m, (p.name, text)
        assert ast.literal_eval(m.group(1).split(" (")[0]) == p.default, (p.name, text)
        if p.type in ("int", "double"):
            assert type_line.startswith("int" if p.type == "int" else "float"), p.name
            r = re.search(r"range (\S+)\.\.(\S+?)([,;.])(?:\s|$)", text)
            assert r, (p.name, text)
            assert (float(r.group(1)), float(r.group(2))) == (p.lower, p.upper), p.name
            if p.constraint:
                assert text[r.end(2):].startswith(", " + p.constraint), p.name
            if p.unit:
                assert "unit: %s" % p.unit in text, p.name
        elif p.type in ("switch", "choice"):
            assert _names_in_braces(type_line) == p.value_names, p.name
            assert type_line.startswith("bool or {" if p.type == "switch" else "{"), p.name
    rendered = pydoc.render_doc(obj, renderer=pydoc.plaintext)
    assert "rotation_steps : int" in rendered


def test_parameter_table_agrees_with_the_c_queries():
    ffi, lib = _lib.ffi, _lib.lib
    table = pkss.parameters()
    assert [p.name for p in table] == _c_param_names()
    assert len(table) == lib.pkss_param_count()
    pid = ffi.new("pkss_param *")
    lo, hi, de = ffi.new("double *"), ffi.new("double *"), ffi.new("double *")
    for p in table:
        assert ffi.string(lib.pkss_param_name(p.id)).decode() == p.name
        assert lib.pkss_param_find(p.name.encode(), pid) == 0 and pid[0] == p.id
        if p.type in ("int", "double"):
            assert lib.pkss_param_bounds(p.id, lo, hi, de) == 0
            assert (lo[0], hi[0], de[0]) == (p.lower, p.upper, p.default), p.name
            assert pkss.param_bounds(p.name) == (p.lower, p.upper, p.default)
        if p.type == "switch":
            assert isinstance(p.default, bool) and set(p.value_names) == {"on", "off"}
        if p.type == "choice":
            assert p.default in p.choices
    # the table's defaults are what a fresh context resolves
    assert pkss.default_params() == {p.name: p.default for p in table}
    as_dicts = [dataclasses.asdict(p) for p in table]
    assert as_dicts[0]["name"] == "points" and set(as_dicts[0]) >= {
        "name", "type", "lower", "upper", "default", "unit", "choices", "constraint", "doc"}


def test_public_api_is_documented_and_typed():
    for name in pkss.__all__:
        obj = getattr(pkss, name)
        if callable(obj):
            assert obj.__doc__, name
    for func in (pkss.register, pkss.devices, pkss.param_bounds, pkss.Context.register,
                 pkss.Context.prepare_cloud, pkss.Result.apply):
        assert inspect.signature(func).return_annotation is not inspect.Signature.empty


@pytest.mark.parametrize("name", [n for n in pkss.PARAM_NAMES
                                  if n not in ("rotation_set", "backend", "device")
                                  and not isinstance(pkss.default_params()[n], bool)])
def test_parameter_bounds(name):
    lo, hi, default = pkss.param_bounds(name)
    step = 0.001 if isinstance(lo, float) else (2 if name in ("rotation_steps", "cell_steps",
                                                             "offset_steps") else 1)
    with pkss.Context(**{name: lo}) as ctx:
        assert ctx.params[name] == lo
        ctx.set(**{name: hi})
        assert ctx.params[name] == hi
        for bad in (hi + step, lo - step):
            with pytest.raises(ValueError) as e:
                ctx.set(**{name: bad})
            assert isinstance(e.value, pkss.InvalidArgument)
            assert e.value.name == "PKSS_ERR_INVALID_ARGUMENT"
            assert name in str(e.value)
            m = re.search(r"must be in \[([^,]+), ([^\]]+)\]", e.value.detail)
            assert m and (float(m.group(1)), float(m.group(2))) == (lo, hi), e.value.detail
        assert ctx.params[name] == hi  # a rejected value leaves the setting


def test_parameter_constraints_carry_the_c_detail():
    with pkss.Context() as ctx:
        with pytest.raises(pkss.InvalidArgument, match="even"):
            ctx.set(rotation_steps=13)
        with pytest.raises(pkss.InvalidArgument, match="odd"):
            ctx.set(offset_steps=4)
        with pytest.raises(ValueError, match="None for the default"):
            ctx.set(points=0)
        with pytest.raises(ValueError, match="must be in"):
            ctx.set(seed=2**70)
        with pytest.raises(ValueError, match="'euler', 'uniform'"):
            ctx.set(rotation_set="random")
        with pytest.raises(ValueError, match="'auto', 'reference', 'opencl'"):
            ctx.set(backend="cuda")
        with pytest.raises(ValueError):
            ctx.set(device=-1)


@pytest.mark.parametrize("kwargs", [
    dict(points=3000.0), dict(points="3000"), dict(points=True), dict(top_k=2.5),
    dict(feature_frac="0.1"), dict(cull_mutual=[1]), dict(refine=2), dict(backend=1),
    dict(rotation_set=True), dict(device=1.5), dict(device=b"cpu")])
def test_parameter_types(kwargs):
    with pytest.raises(TypeError, match=next(iter(kwargs))):
        pkss.Context(**kwargs)


def test_unknown_keyword_lists_the_valid_names(small):
    for call in (lambda: pkss.register(small, small, pointz=1000),
                 lambda: pkss.Context(pointz=1000),
                 lambda: pkss.Context().set(pointz=1000)):
        with pytest.raises(TypeError) as e:
            call()
        msg = str(e.value)
        assert "'pointz'" in msg and "did you mean 'points'" in msg
        assert all(n in msg for n in pkss.PARAM_NAMES)


def test_settings_stick_until_reset():
    with pkss.Context(points=500, refine=False, rotation_set="uniform",
                      backend="reference", device=0) as ctx:
        p = ctx.params
        assert (p["points"], p["refine"], p["rotation_set"], p["backend"], p["device"]) == \
            (500, False, "uniform", "reference", "0")
        ctx.set(cell_steps=24, feature_frac=0.2, drop_nonfinite=True, device="cpu")
        p = ctx.params
        assert (p["points"], p["cell_steps"], p["feature_frac"], p["drop_nonfinite"],
                p["device"]) == (500, 24, 0.2, True, "cpu")
        ctx.reset()
        assert ctx.params == pkss.default_params()


# --------------------------------------------------------------------- input
def _pair(seed=1):
    src = shape()
    T = random_similarity(np.random.default_rng(seed), 2.0)
    return src, apply(T, shape(seed=4)), T


def test_array_likes_give_identical_results(small):
    src, tgt, _ = _pair()
    ref = pkss.register(src, tgt, **FAST).transform
    big = np.zeros((2 * len(src), 5))
    big[::2, 1:4] = src
    views = {
        "list": src.tolist(),
        "tuple": tuple(map(tuple, src)),
        "fortran": np.asfortranarray(src),
        "strided": big[::2, 1:4],
        "longdouble": src.astype(np.longdouble),
        "readonly": np.frombuffer(src.tobytes()).reshape(-1, 3),
    }
    for kind, s in views.items():
        np.testing.assert_allclose(pkss.register(s, tgt, **FAST).transform, ref, atol=1e-12,
                                   err_msg=kind)
    # float32 and integer input are converted exactly; compare with the
    # float64 version of the same numbers.
    for conv in (lambda a: a.astype(np.float32), lambda a: np.round(a * 1000).astype(np.int32),
                 lambda a: np.round((a + 20) * 1000).astype(np.uint32)):
        s, t = conv(src), conv(tgt)
        np.testing.assert_allclose(
            pkss.register(s, t, **FAST).transform,
            pkss.register(s.astype(np.float64), t.astype(np.float64), **FAST).transform,
            atol=1e-12)


class FakePointCloud:
    """Duck-types open3d.geometry.PointCloud: `.points` is (N, 3)-like."""

    def __init__(self, xyz):
        self.points = [list(p) for p in xyz]


def test_objects_with_points_attribute():
    src, tgt, _ = _pair()
    a = pkss.register(FakePointCloud(src), FakePointCloud(tgt), **FAST).transform
    np.testing.assert_allclose(a, pkss.register(src, tgt, **FAST).transform, atol=1e-12)


def test_open3d_point_cloud():
    o3d = pytest.importorskip("open3d", reason="Open3D is not installed")
    src, tgt, _ = _pair()
    pcs = []
    for xyz in (src, tgt):
        pc = o3d.geometry.PointCloud()
        pc.points = o3d.utility.Vector3dVector(xyz)
        pcs.append(pc)
    np.testing.assert_allclose(pkss.register(*pcs, **FAST).transform,
                               pkss.register(src, tgt, **FAST).transform, atol=1e-12)


def _coplanar():
    xy = np.random.default_rng(0).uniform(-1, 1, size=(200, 2))
    return np.c_[xy, np.zeros(200)]


def _with_bad_row(value, row=7):
    a = shape()
    a[row, 1] = value
    return a


BAD_INPUTS = [
    # (input, status name, words the message must contain)
    (np.zeros((10, 2)), "PKSS_ERR_INVALID_ARGUMENT", "expected an (N, 3) array, got shape (10, 2)"),
    (np.zeros(30), "PKSS_ERR_INVALID_ARGUMENT", "got shape (30,)"),
    (np.zeros((10, 3, 1)), "PKSS_ERR_INVALID_ARGUMENT", "got shape (10, 3, 1)"),
    ([[1, 2, 3], [4, 5]], "PKSS_ERR_INVALID_ARGUMENT", "cannot convert list"),
    (np.array([["a", "b", "c"]] * 50), "PKSS_ERR_INVALID_ARGUMENT", "got dtype <U1"),
    (shape().astype(complex), "PKSS_ERR_INVALID_ARGUMENT", "got dtype complex128"),
    (shape() > 0, "PKSS_ERR_INVALID_ARGUMENT", "got dtype bool"),
    (None, "PKSS_ERR_INVALID_ARGUMENT", "got dtype object"),
    (np.zeros((0, 3)), "PKSS_ERR_EMPTY_INPUT", "empty"),
    (shape()[:10], "PKSS_ERR_TOO_FEW_POINTS", "10 finite points"),
    (_with_bad_row(np.nan), "PKSS_ERR_NONFINITE", "row 7 has a non-finite coordinate"),
    (_with_bad_row(-np.inf, 123), "PKSS_ERR_NONFINITE", "row 123"),
    (_coplanar(), "PKSS_ERR_DEGENERATE", "coplanar"),
    (np.ones((100, 3)), "PKSS_ERR_DEGENERATE", "identical"),
    (np.outer(np.arange(100.0), [1, 2, 3]), "PKSS_ERR_DEGENERATE", "collinear"),
]


@pytest.mark.parametrize("which", ["source", "target"])
@pytest.mark.parametrize("bad,status,words", BAD_INPUTS,
                         ids=[b[1] + "-" + str(i) for i, b in enumerate(BAD_INPUTS)])
def test_bad_input(which, bad, status, words):
    good = shape()
    args = (bad, good) if which == "source" else (good, bad)
    with pytest.raises(ValueError) as e:
        pkss.register(*args, **FAST)
    err = e.value
    assert isinstance(err, pkss.InvalidArgument)
    assert err.name == status and err.status == getattr(_lib.lib, status)
    assert words in err.detail
    assert which in err.detail  # names the argument
    with pkss.Context(**FAST) as ctx:
        with pytest.raises(pkss.InvalidArgument) as e2:
            ctx.prepare_cloud(bad)
        assert e2.value.name == status


def test_drop_nonfinite():
    src, tgt, T = _pair()
    src = src.copy()
    src[[3, 50, 51]] = [np.nan, 0, 0]
    src[99, 2] = np.inf
    res = pkss.register(src, tgt, drop_nonfinite=True, **FAST)
    assert res.counts.source.nonfinite == 4
    assert res.counts.source.input == len(src)
    with pkss.Context(drop_nonfinite=True, **FAST) as ctx:
        assert ctx.prepare_cloud(src).counts.nonfinite == 4


# -------------------------------------------------------------------- errors
def test_every_status_maps_to_an_exception_class():
    for value, name in _lib.ffi.typeof("pkss_status").elements.items():
        if value == 0:
            continue
        err = pkss.Error.class_for(value)(value, "some detail")
        assert err.name == name and err.status == value and err.detail == "some detail"
        assert str(err) == "%s: some detail" % name
        assert pkss.status_string(value)
        assert isinstance(err, pkss.Error)
        cancelled = value == _lib.lib.PKSS_ERR_CANCELLED
        assert isinstance(err, pkss.Cancelled) == cancelled
        assert isinstance(err, ValueError) == (value < 100 and not cancelled)
        assert isinstance(err, pkss.DeviceError) == (200 <= value < 300)
        io = value == _lib.lib.PKSS_ERR_IO  # a file, not memory
        assert isinstance(err, MemoryError) == (100 <= value < 200 and not io)
        assert isinstance(err, pkss.FileError) == io
        copy = pickle.loads(pickle.dumps(err))
        assert (type(copy), copy.status, copy.detail) == (type(err), value, "some detail")
    assert pkss.status_name(12345) == "PKSS_UNKNOWN_STATUS"


def test_device_errors_are_device_errors():
    with pkss.Context(backend="opencl", device="no-such-device-for-pkss-tests") as ctx:
        with pytest.raises(pkss.Error) as e:
            ctx.prepare()
    assert isinstance(e.value, pkss.DeviceError), e.value
    assert e.value.detail


def test_the_library_prints_nothing(capfd):
    src, tgt, _ = _pair()
    pkss.register(src, tgt, **FAST)
    with pytest.raises(pkss.Error):
        pkss.register(src, np.ones((50, 3)), **FAST)
    pkss.devices()
    out, err = capfd.readouterr()
    assert out == "" and err == ""


# ----------------------------------------------------------------- lifetimes
def _destroy_spy(monkeypatch):
    freed = {"pkss_context_destroy": 0, "pkss_cloud_destroy": 0}

    def counting(name):
        def factory(real):
            def destroy(ptr):
                freed[name] += 1
                real(ptr)
            return destroy
        return factory

    monkeypatch.setattr(pkss, "lib", LibSpy(_lib.lib, {n: counting(n) for n in freed}))
    return freed


def test_garbage_collection_frees_c_objects(monkeypatch):
    freed = _destroy_spy(monkeypatch)
    ctx = pkss.Context(**FAST)
    cloud = ctx.prepare_cloud(shape())
    refs = weakref.ref(ctx), weakref.ref(cloud)
    del ctx, cloud
    gc.collect()
    assert refs[0]() is None and refs[1]() is None
    assert freed == {"pkss_context_destroy": 1, "pkss_cloud_destroy": 1}


def test_close_is_idempotent_and_frees_once(monkeypatch):
    freed = _destroy_spy(monkeypatch)
    with pkss.Context(**FAST) as ctx:
        with ctx.prepare_cloud(shape()) as cloud:
            assert not cloud.closed
        assert cloud.closed
        cloud.close()
    assert ctx.closed
    ctx.close()
    del ctx, cloud
    gc.collect()
    assert freed == {"pkss_context_destroy": 1, "pkss_cloud_destroy": 1}


def test_use_after_close_raises():
    ctx = pkss.Context(**FAST)
    cloud = ctx.prepare_cloud(shape())
    other = pkss.Context(**FAST)
    cloud2 = other.prepare_cloud(shape())
    ctx.close()
    for call in (lambda: ctx.register(shape(), shape()), lambda: ctx.prepare_cloud(shape()),
                 lambda: ctx.set(points=500), lambda: ctx.params, lambda: ctx.prepare(),
                 lambda: ctx.reset(), lambda: ctx.device_name):
        with pytest.raises(ValueError, match="Context is closed"):
            call()
    assert "closed" in repr(ctx)
    # A cloud outlives the context that made it.
    assert len(cloud) == 256
    other.register(cloud, cloud2)
    cloud.close()
    for call in (lambda: len(cloud), lambda: cloud.points, lambda: cloud.counts,
                 lambda: other.register(cloud, cloud2), lambda: other.register(cloud2, cloud)):
        with pytest.raises(ValueError, match="Cloud is closed"):
            call()
    other.close()


def test_result_is_plain_python_and_numpy():
    src, tgt, _ = _pair()
    with pkss.Context(**FAST) as ctx:
        res = ctx.register(src, tgt)
    assert res.transform.shape == (4, 4) and res.transform.dtype == np.float64
    assert isinstance(res.scale, float) and isinstance(res.candidates[0].offset_index, int)
    assert "Result(scale=" in repr(res) and "Candidate(" in repr(res.candidates[0])
    # how far each candidate got: the winner ran the full refinement
    assert res.candidates[res.winner].stage == "refined"
    assert {c.stage for c in res.candidates} <= {"search", "coarse", "stopped", "refined"}
    with pkss.Context(**dict(FAST, refine=False)) as ctx:
        raw = ctx.register(src, tgt)
    assert [c.stage for c in raw.candidates] == ["search"] * len(raw.candidates)


# ------------------------------------------------------------------- devices
def test_devices():
    devs = pkss.devices()
    assert isinstance(devs, list) and isinstance(devs, pkss.DeviceList)
    if not devs:
        assert devs.reason, "an empty device list must say why"
        return
    assert devs.reason == ""
    for i, d in enumerate(devs):
        assert isinstance(d, pkss.Device) and d.index == i
        assert d.name and d.platform and d.version.startswith("OpenCL")
        assert d.compute_units >= 1 and d.global_mem_bytes > 0
        assert isinstance(d.is_gpu, bool) and isinstance(d.has_fp64, bool)
