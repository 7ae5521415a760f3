"""Bad input to the ASF/AMC reader and degenerate curves in core, without bpy.

A bounded hypothesis fuzz mutates the real CMU files (the mutators of tools/fuzz_readers.py: truncation,
garbage bytes, dropped / repeated lines, wrong value counts, NaN / inf / huge numbers, missing sections,
latin-1 / UTF-16 / BOM encodings, empty and binary files): every case must end in a valid Clip or in a
ShapeSigError with a one-line message, and mutations that keep the file valid must give the same clip.
The long fuzz is ``tools/fuzz_readers.py --cases N --seed S``.
"""

import importlib.util
import pathlib
import random
import tempfile
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from blender_shapesig.core import log_signature, signature, srvt
from blender_shapesig.core.io.acclaim import decode_text, load_acclaim, parse_amc, parse_asf
from blender_shapesig.core.clip.clip import Clip, restrict_to_shared
from blender_shapesig.core.errors import CurveError, ParseError, ShapeSigError
from blender_shapesig.core.metrics import METRICS, clip_distance

ROOT = pathlib.Path(__file__).resolve().parents[3]
ACC = ROOT / "tests" / "data" / "acclaim"

_spec = importlib.util.spec_from_file_location("fuzz_readers", ROOT / "tools" / "fuzz_readers.py")
fz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fz)


def _short_amc(path, frames):
    """The AMC's header and first ``frames`` frames (a valid, smaller file)."""
    out, count = [], 0
    for line in path.read_bytes().split(b"\n"):
        if line.strip().isdigit():
            count += 1
            if count > frames:
                break
        out.append(line)
    return b"\n".join(out) + b"\n"


ASF = (ACC / "09-run.asf").read_bytes()
AMC = _short_amc(ACC / "09_02.amc", 24)


@pytest.fixture(scope="module")
def original():
    with tempfile.TemporaryDirectory() as tmp:
        outcome, detail = fz.read_acclaim_case(ASF, AMC, tmp)
        assert outcome == "ok", detail
        return load_acclaim(pathlib.Path(tmp) / "take.amc", pathlib.Path(tmp) / "skel.asf").rotations


# ------------------------------------------------------------------------------------ fuzz (bounded)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(fz.KINDS), which=st.sampled_from(("asf", "amc")), seed=st.integers(0, 2 ** 32 - 1))
def test_mutated_acclaim_gives_clip_or_our_one_line_error(original, kind, which, seed):
    rng = random.Random(seed)
    asf, amc = ASF, AMC
    if which == "asf":
        asf = fz.mutate(asf, kind, rng, "asf")
    else:
        amc = fz.mutate(amc, kind, rng, "amc")
    expected = original if kind in fz.PRESERVING else None
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no silent NaN arithmetic either
        outcome, detail = fz.read_acclaim_case(asf, amc, tmp, expected, timeout=20)
    assert outcome in ("ok", "error"), f"{kind} on {which}: {detail}"


@pytest.mark.parametrize("kind", fz.KINDS)
@pytest.mark.parametrize("which", ("asf", "amc"))
def test_every_mutation_kind_once(original, kind, which):
    rng = random.Random(1234)
    data = {"asf": ASF, "amc": AMC}
    data[which] = fz.mutate(data[which], kind, rng, which)
    with tempfile.TemporaryDirectory() as tmp:
        outcome, detail = fz.read_acclaim_case(data["asf"], data["amc"], tmp,
                                               original if kind in fz.PRESERVING else None)
    assert outcome != "FAIL", detail
    if kind in fz.PRESERVING:
        assert outcome == "ok"
    if kind in ("empty", "whitespace", "binary", "truncate_line", "wrong_format") and which == "asf":
        assert outcome == "error"


def test_mutators_change_the_file_and_are_deterministic():
    for kind in fz.KINDS:
        a = fz.mutate(AMC, kind, random.Random(5), "amc")
        b = fz.mutate(AMC, kind, random.Random(5), "amc")
        assert a == b, kind
        if kind != "cr" or b"\r" not in AMC:
            assert a != AMC, kind


# ------------------------------------------------------------------------- specific bad input, messages


def _err(tmp_path, asf, amc, *needles):
    (tmp_path / "s.asf").write_bytes(asf)
    (tmp_path / "t.amc").write_bytes(amc)
    with pytest.raises(ParseError) as info:
        load_acclaim(tmp_path / "t.amc", tmp_path / "s.asf")
    msg = str(info.value)
    assert "\n" not in msg
    for n in needles:
        assert n in msg, msg
    return info.value


def test_nan_inf_and_junk_numbers_name_the_line(tmp_path):
    lines = AMC.split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(b"lfemur"))
    for bad, what in ((b"nan", "not a finite number"), (b"inf", "not a finite number"),
                      (b"1e999", "not a finite number"), (b"1.2.3", "is not a number")):
        mutated = list(lines)
        mutated[i] = b"lfemur " + bad + b" 0 0"
        e = _err(tmp_path, ASF, b"\n".join(mutated), what, "lfemur")
        assert e.line == i + 1 and e.path.endswith("t.amc")


def test_wrong_value_count_truncation_and_missing_sections(tmp_path):
    lines = AMC.split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(b"lfemur"))
    mutated = list(lines)
    mutated[i] = b"lfemur 1 2"
    _err(tmp_path, ASF, b"\n".join(mutated), "needs 3 values (its dof), got 2")
    cut = AMC[: len(AMC) * 2 // 3]
    cut = cut[: cut.rindex(b"\n")]
    _err(tmp_path, ASF, cut, "(truncated file?)")
    for cut_at in (b"\nlfemur ", b"\nlhumerus "):  # cut inside a bone name or after it on the last line
        end = AMC.rindex(cut_at) + (4 if cut_at == b"\nlfemur " else len(cut_at) + 3)
        _err(tmp_path, ASF, AMC[:end], "(truncated file?)")
    _err(tmp_path, ASF, b"", "empty AMC file")
    _err(tmp_path, ASF, b":FULLY-SPECIFIED\n:DEGREES\n", "no frames")
    no_hier = ASF[: ASF.index(b":hierarchy")]
    _err(tmp_path, no_hier, AMC, "missing :hierarchy section")
    _err(tmp_path, bytes(range(256)) * 4, AMC, "s.asf")
    _err(tmp_path, ASF, ASF, "t.amc")  # an ASF given as the motion


def test_huge_values_are_finite_rotations(tmp_path):
    lines = AMC.split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(b"lfemur"))
    lines[i] = b"lfemur 1e300 -1e300 1.7976931348623157e308"
    (tmp_path / "s.asf").write_bytes(ASF)
    (tmp_path / "t.amc").write_bytes(b"\n".join(lines))
    clip = load_acclaim(tmp_path / "t.amc", tmp_path / "s.asf")
    assert fz.check_clip(clip) is None


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "utf-16-be-bom", "utf-32", "latin-1-comment"])
def test_encodings(tmp_path, original, encoding):
    def enc(data):
        text = data.decode("utf-8")
        if encoding == "utf-16-be-bom":
            return b"\xfe\xff" + text.encode("utf-16-be")
        if encoding == "latin-1-comment":
            return ("# données\n" + text).encode("latin-1")
        return text.encode(encoding)

    (tmp_path / "s.asf").write_bytes(enc(ASF))
    (tmp_path / "t.amc").write_bytes(enc(AMC))
    clip = load_acclaim(tmp_path / "t.amc", tmp_path / "s.asf")
    np.testing.assert_array_equal(clip.rotations, original)
    assert decode_text(b"\xef\xbb\xbfabc") == "abc"
    # text and bytes input too
    sk = parse_asf(enc(ASF))
    assert parse_amc(enc(AMC), sk).frames == original.shape[0]


def test_no_such_file_and_folder(tmp_path):
    with pytest.raises(ParseError, match="no such AMC file"):
        load_acclaim(tmp_path / "x.amc", tmp_path / "x.asf")
    (tmp_path / "t.amc").write_bytes(AMC)
    with pytest.raises(ParseError, match="no .asf skeleton beside"):
        load_acclaim(tmp_path / "t.amc")
    with pytest.raises(ParseError, match="no such ASF file"):
        load_acclaim(tmp_path / "t.amc", tmp_path / "missing.asf")


# ---------------------------------------------------------------------------------- degenerate curves


@pytest.fixture(scope="module")
def walk():
    return load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf")


def _clip(name, R, bones):
    return Clip(name=name, bones=bones, rotations=R)


def test_constant_clip_srvt_and_signatures_are_zero_not_nan(walk):
    R = np.repeat(walk.rotations[5:6], 40, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        q = srvt(R)
        assert q.shape == (39, R.shape[1], 3) and np.all(q == 0)
        s = signature(R, 3)
        ls = log_signature(R, 3)
    assert np.all(np.isfinite(s)) and np.all(s == 0)
    assert np.all(np.isfinite(ls)) and np.all(ls == 0)
    const = _clip("const", R, walk.bones)
    for metric in METRICS:
        d_self = clip_distance(const, const, metric)
        d_walk = clip_distance(const, walk, metric)
        assert d_self == 0.0, metric
        assert np.isfinite(d_walk) and d_walk > 0, metric
    # one frame: the signature metrics treat it as a constant path; l2 / elastic need two frames
    one = _clip("one", walk.rotations[:1], walk.bones)
    for metric in ("group", "concat", "linear", "sim"):
        assert clip_distance(one, walk, metric) == pytest.approx(clip_distance(const, walk, metric))
    for metric in ("l2", "elastic"):
        with pytest.raises(CurveError, match="clip .one. has 1 frame; the .* needs at least two frames") as info:
            clip_distance(one, walk, metric)
        assert "\n" not in str(info.value)


def test_two_frame_clips(walk):
    two = _clip("two", walk.rotations[:2], walk.bones)
    for metric in METRICS:
        d = clip_distance(two, walk, metric)
        assert np.isfinite(d) and d > 0, metric
        assert clip_distance(two, two, metric) == pytest.approx(0.0, abs=1e-5), metric


def test_nan_and_no_shared_bones_are_curve_errors(walk):
    R = walk.rotations.copy()
    R[3, 2, 0, 0] = np.nan
    with pytest.raises(CurveError, match="NaN or infinite"):
        _clip("nan", R, walk.bones)
    R[3, 2, 0, 0] = np.inf
    with pytest.raises(CurveError, match="NaN or infinite"):
        _clip("inf", R, walk.bones)
    rt = np.zeros((walk.frames, 3))
    rt[4, 1] = np.inf
    with pytest.raises(CurveError, match="root translation contains NaN or infinite"):
        Clip(name="far", bones=walk.bones, rotations=walk.rotations, root_translation=rt)
    other = _clip("other", walk.rotations[:, :3], ("a", "b", "c"))
    with pytest.raises(CurveError, match="share no bones"):
        restrict_to_shared(walk, other)
    for metric in METRICS:
        with pytest.raises(ShapeSigError, match="share no bones"):
            clip_distance(walk, other, metric)
