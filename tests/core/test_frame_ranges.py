"""The one frame-range rule (``errors.check_frame_range``) and its users: ``Clip.crop`` refuses a range outside the
clip unless asked to clamp, the blends' ranges and the readers' crops say so in the same words."""

import numpy as np
import pytest

from blender_shapesig.core.blend import crop_range, parse_range
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError, check_frame_range
from blender_shapesig.core.io.sources import after_read


def _clip(frames=10, start=5):
    R = np.broadcast_to(np.eye(3), (frames, 2, 3, 3)).copy()
    return Clip(name="c", bones=("a", "b"), rotations=R, frame_start=start,
                root_translation=np.arange(frames * 3, dtype=float).reshape(frames, 3))


def test_rule_inside_outside_and_length():
    assert check_frame_range(5, 14, 5, 14) == (5, 14)
    assert check_frame_range(None, None, 5, 14) == (5, 14)
    assert check_frame_range(3, 3, None, None, frames=1) == (3, 3)
    with pytest.raises(ShapeSigError, match=r"^the frame range 4\.\.10 is outside clip 'c''s frames 5\.\.14$"):
        check_frame_range(4, 10, 5, 14, "clip 'c'")
    with pytest.raises(ShapeSigError, match=r"^the frame range 7\.\.7 of x must end after it starts \(at least 2"):
        check_frame_range(7, 7, 5, 14, "x")
    with pytest.raises(ShapeSigError, match="must end at or after it starts"):
        check_frame_range(8, 7, None, None, "x", frames=1)
    with pytest.raises(ShapeSigError, match="frame start"):
        check_frame_range(1.5, 7, None, None)


def test_clamp_only_when_asked():
    assert check_frame_range(1, 100, 5, 14, clamp=True) == (5, 14)
    assert check_frame_range(None, 9, 5, 14, clamp=True) == (5, 9)
    for s, e in ((20, 30), (1, 4)):  # missing the frames entirely: refused even when clamping
        with pytest.raises(ShapeSigError, match="is outside"):
            check_frame_range(s, e, 5, 14, clamp=True)


def test_crop_keeps_frames_and_refuses_outside():
    c = _clip()
    got = c.crop(7, 9)
    assert (got.frame_start, got.frames) == (7, 3)
    np.testing.assert_array_equal(got.root_translation, c.root_translation[2:5])
    assert c.crop(9, 9).frames == 1  # one frame is a pose: a crop may keep it
    with pytest.raises(ShapeSigError, match=r"the frame range 1\.\.9 is outside clip 'c''s frames 5\.\.14"):
        c.crop(1, 9)
    with pytest.raises(ShapeSigError, match="is outside"):
        c.crop(end=20)
    clamped = c.crop(1, 9, clamp=True)
    assert (clamped.frame_start, clamped.frame_end) == (5, 9)


def test_readers_crop_clamps_on_purpose():
    """``after_read``: one --start/--end for clips of any length, clamped to each; a clip it misses is refused."""
    short, long = _clip(10, 1), _clip(40, 1)
    got = after_read([short, long], start=5, end=30)
    assert [(c.frame_start, c.frame_end) for c in got] == [(5, 10), (5, 30)]
    with pytest.raises(ShapeSigError, match="is outside"):
        after_read([short], start=20)


def test_blend_ranges_say_it_in_the_same_words():
    c = _clip()
    got = crop_range(c, "6:9", "range of clip A")
    assert (got.frame_start, got.frames, got.meta["range"]) == (6, 4, (6, 9))
    with pytest.raises(ShapeSigError, match=r"the frame range 6\.\.20 is outside range of clip A of 'c''s frames"):
        crop_range(c, "6:20", "range of clip A")
    with pytest.raises(ShapeSigError, match=r"the frame range 9\.\.6 of --range-a must end after it starts"):
        parse_range("9:6", "--range-a")
