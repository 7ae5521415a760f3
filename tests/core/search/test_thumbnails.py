"""Pose thumbnails: the rasterizer against closed forms (a disc's area, a capsule's area at any angle, a rectangle's
fractional coverage), its PNG files against another decoder (matplotlib's, through Pillow), and the strips of real
CMU clips: the same take from AMC and from the Daz BVH conversion agrees, a walk and a jump differ, pictures are
kept in the cache's own folder and read back from it by a new store, and a window marks its poses."""

import math
import os
import pathlib

import numpy as np
import pytest

from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.search import SignatureCache
from blender_shapesig.core.search import thumbnails as T
from blender_shapesig.core.search.local.entry import Refusal
from blender_shapesig.core.io import sources
from blender_shapesig.core.raster import Canvas, png_bytes, write_png
from tests.helpers.png import read_png

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _alpha(canvas):
    return canvas.pixels[..., 3].astype(np.float64) / 255.0


@pytest.mark.parametrize("centre,radius", [((32.0, 30.0), 10.0), ((31.3, 29.7), 7.25), ((20.5, 40.5), 3.5)])
def test_disc_covers_its_area(centre, radius):
    c = Canvas(64, 64, (0, 0, 0, 0))
    c.disc(centre, radius, (1, 1, 1, 1))
    # the one-pixel ramp integrated over the plane: pi r^2 + pi / 12
    assert _alpha(c).sum() == pytest.approx(math.pi * (radius ** 2 + 1 / 12), rel=0.005)


@pytest.mark.parametrize("angle", [0.0, 0.3, math.pi / 4, 1.2])
def test_line_covers_a_capsule_at_any_angle(angle):
    """A capsule of length L and width w covers w L + pi ((w/2)^2 + 1/12) pixels, however it is turned: each
    placement within 2.5 % (pixel-centre sampling), their mean over sub-pixel offsets within 0.4 %."""
    L, w = 40.0, 6.0
    areas = []
    for dx, dy in np.random.default_rng(1).random((40, 2)):
        a = np.array([50.0 + dx, 50.0 + dy])
        b = a + L * np.array([math.cos(angle), math.sin(angle)])
        c = Canvas(100, 100, (0, 0, 0, 0))
        c.line(a, b, w, (0, 0, 0, 1))
        areas.append(_alpha(c).sum())
    exact = w * L + math.pi * ((w / 2) ** 2 + 1 / 12)
    assert np.allclose(areas, exact, rtol=0.025)
    assert np.mean(areas) == pytest.approx(exact, rel=0.004)


def test_polyline_paints_a_joint_once():
    """Two capsules meeting at a point: the union's area (no double painting where they overlap)."""
    c = Canvas(100, 100, (0, 0, 0, 0))
    c.polyline([(20, 50), (50, 50), (80, 50)], 4.0, (0, 0, 0, 1))
    assert _alpha(c).sum() == pytest.approx(4.0 * 60 + math.pi * (4 + 1 / 12), rel=0.005)
    assert _alpha(c).max() <= 1.0


def test_rect_fractional_edges():
    c = Canvas(20, 20, (0, 0, 0, 0))
    c.rect(2.25, 3.5, 10.75, 6.0, (1, 0, 0, 1))
    assert _alpha(c).sum() == pytest.approx((10.75 - 2.25) * (6.0 - 3.5), abs=0.02)


def test_over_compositing_of_half_transparent_colour():
    c = Canvas(4, 4, (1, 1, 1, 1))
    c.rect(0, 0, 4, 4, (0, 0, 0, 0.5))
    assert np.all(np.abs(c.pixels[..., :3].astype(int) - 128) <= 1) and np.all(c.pixels[..., 3] == 255)


def test_png_round_trip_and_another_decoder(tmp_path):
    from matplotlib.image import imread

    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (17, 23, 4), dtype=np.uint8)
    path = write_png(tmp_path / "x.png", img)
    assert np.array_equal(read_png(path), img)
    other = np.round(imread(path) * 255).astype(np.uint8)  # Pillow's decoder
    assert np.array_equal(other, img)
    assert png_bytes(img)[:8] == b"\x89PNG\r\n\x1a\n"


def _item(rel, asf=None):
    return sources.library([str(DATA / rel)], asf=None if asf is None else str(DATA / asf))[0]


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return SignatureCache(tmp_path_factory.mktemp("cache"))


def _strip(item, store, **kw):
    return T.entry_strip(T.local_entry_of(item, store), **kw)


def _iou(a, b, grow=2):
    ma, mb = T.figure_mask(a, grow), T.figure_mask(b, grow)
    return (ma & mb).sum() / (ma | mb).sum()


def test_same_take_from_amc_and_daz_bvh_agrees(store):
    amc = _strip(_item("acclaim/07_01.amc", "acclaim/07-walk.asf"), store)
    bvh = _strip(_item("bvh/07_01.bvh"), store)
    assert amc.shape == bvh.shape == (T.HEIGHT, T.SLOT * T.POSES, 4)
    assert _iou(amc, bvh) >= 0.7


def test_walk_and_jump_differ(store):
    walk, jump = _strip(_item("bvh/07_01.bvh"), store), _strip(_item("bvh/13_32.bvh"), store)
    assert _iou(walk, jump) < 0.45
    # another walk looks more like the walk than the jump does
    other = _strip(_item("bvh/08_01.bvh"), store)
    assert _iou(walk, other) > _iou(walk, jump) + 0.2


def test_key_times_are_extremes_in_even_slots():
    """A pose that swings as sin(2 pi u): the extremes of its slots (two slots: the two peaks)."""
    u = np.linspace(0, 1, 121)
    P = np.zeros((121, 11, 3))
    P[:, :, 0] = np.sin(2 * np.pi * u)[:, None]
    times = T.key_times(P, 2)
    assert times == pytest.approx([0.25, 0.75], abs=0.01)
    inside = T.key_times(P, 3, window=(0.5, 0.9))
    assert np.all((inside >= 0.5 - 1e-9) & (inside <= 0.9 + 1e-9)) and np.all(np.diff(inside) > 0)


def test_pictures_are_cached_beside_the_entries(tmp_path):
    item = _item("bvh/09_02.bvh")
    cache = SignatureCache(tmp_path)
    path, made = T.thumbnail(item, cache)
    assert made and os.path.dirname(path) == cache.path and path.endswith(".png")
    assert np.array_equal(read_png(path), _strip(item, cache))
    # a new store (a new process) finds the picture without reading the clip
    again = SignatureCache(tmp_path)
    never = sources.LibraryItem(item.name, item.key, lambda: pytest.fail("the clip was read again"))
    assert T.thumbnail(never, again) == (path, False)
    # another window is another picture; Clear Index removes pictures with the entries it wrote
    wpath, made = T.thumbnail(item, again, window=(0.2, 0.6))
    assert made and wpath != path
    again.clear()
    assert not os.path.exists(path) and not os.path.exists(wpath)


def test_window_is_marked_in_the_accent_colour(store):
    item = _item("bvh/13_32.bvh")
    whole, moment = _strip(item, store), _strip(item, store, window=(0.4, 0.7))
    accent = (np.abs(moment[..., :3].astype(int) - [230, 107, 26]).max(axis=-1) < 30)
    assert accent[T.GROUND:].any() and not (np.abs(whole[..., :3].astype(int) - [230, 107, 26]).max(axis=-1) < 30).any()


def test_no_picture_without_an_index_folder_or_legs(tmp_path):
    with pytest.raises(ShapeSigError, match="index folder"):
        T.thumbnail(_item("bvh/09_02.bvh"), SignatureCache(None))
    refused = Refusal("arm", "local search needs the legs")
    cache = SignatureCache(tmp_path)
    cache.local.put("k", __import__("blender_shapesig.core.search.local.features", fromlist=["x"]).settings_key(), [refused])
    with pytest.raises(ShapeSigError, match="no picture of 'arm'"):
        T.thumbnail(sources.LibraryItem("arm", "k", lambda: []), cache)
