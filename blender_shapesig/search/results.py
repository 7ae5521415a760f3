"""What an animator does with a result row of the search panel: assign it to the armature, or preview it and
stop (``library`` owns the search itself). Assign never orphans the replaced action (``action_io.assign_action``
stashes it); Stop restores exactly the state before Preview and removes an action written only for it. A row
remembers the identity of what it names (``row.target``: the action's read hash or the file's path, size and time
at the search; ``row.written``: the actions written for it and their hashes): Assign, Preview, Blend and Why refuse
a target that changed since (an action deleted and another renamed to its name, a file replaced) in one line."""

import json

import bpy

from .. import compat
from ..actions import action_io, scene_motion
from ..rigs import retarget, rigmap
from . import library
from ..actions.action_hashes import read_hash
from ..core.io import sources
from ..core.errors import ShapeSigError
from ..core.measure_words import ENGINES
from ..properties import results_of

__all__ = ["selected_action", "result_action", "start_preview", "stop_preview", "preview_result", "assign_result",
           "window_action", "explain_result", "expected_hash", "check_action", "changed_error", "take_moments",
           "moment_problem", "step_moment"]


def changed_error(label):
    return ShapeSigError(f"the result {label!r} changed since the search; search again")


def expected_hash(row, name):
    """The read hash the action ``name`` had for ``row``: one written for it, or the row's own action at the
    search; "" when the row does not know it."""
    written = json.loads(row.written) if row.written else {}
    if name in written:
        return written[name]
    return row.target if (row.is_action and not row.spec and name == row.source) else ""


def check_action(row, action):
    """Refuse ``action`` when it is not what ``row`` named (another content under the name)."""
    expected = expected_hash(row, action.name)
    if expected and read_hash(action) != expected:
        raise changed_error(row.label or row.name)


def _check_file(row):
    """Refuse a file row whose file was replaced or changed since the search."""
    if row.is_action and not row.spec:
        return  # an action of this file: check_action
    if row.target and sources.file_identity(row.spec or row.source) != row.target:
        raise changed_error(row.label or row.name)


def _remember(row, action):
    written = json.loads(row.written) if row.written else {}
    written[action.name] = read_hash(action)
    row.written = json.dumps(written)


def selected_action(context, settings):
    """(armature, action) of the selected result (``result_action``); ShapeSigError with a clear message."""
    library.check_problem(library.result_problem(context, settings))
    obj = library.active_armature(context)
    return obj, result_action(settings, obj, results_of().results[results_of().results_index])


def result_action(settings, obj, row):
    """The bpy action of a result row; a folder clip is first read (``core.io.sources``) and written as a new
    action on ``obj`` (the row then names that action; ``row.spec`` keeps the file). A moment (``row.frame_last``):
    its window as an action (``window_action``)."""
    if row.frame_last:
        return window_action(settings, obj, row)
    if row.is_action:
        action = bpy.data.actions.get(row.source)
        if action is not None:
            check_action(row, action)
            return _on_obj(row, obj, action)
        if not row.spec:
            raise ShapeSigError(f"the action {row.source!r} no longer exists")
        row.is_action, row.source = False, row.spec  # its written action was undone or removed: read it again
    _check_file(row)
    clip = _file_clip(settings, row)
    if retarget.needs_retarget(clip, obj):
        action, kept = retarget.action_on_armature(clip, "auto", obj, _on_name(clip.name, obj))
        row.kept = ", ".join(kept)
    else:
        action = scene_motion.write_motion(clip, obj, name=clip.name)
    row.is_action = True
    row.source = action.name
    _remember(row, action)
    return action


def _on_name(source, obj):
    from ..blend.blend_actions import unique_action_name

    return unique_action_name(f"{source} on {obj.name}")


def _on_obj(row, obj, action, frame_range=None, name=None):
    """``action`` as ``obj`` plays it: itself when it is of ``obj``'s rig, else (another rig's) retargeted once
    onto ``obj`` (``retarget``) as a new action remembered in ``row.on_armature``; the source is only read."""
    owner = library.owner_armature(action, obj)
    if not rigmap.across_rigs(obj, owner) and frame_range is None:
        return action
    got = bpy.data.actions.get(row.on_armature) if row.on_armature else None
    if got is not None:
        check_action(row, got)
        return got
    name = name or action.name
    clip = scene_motion.read_motion(action, owner, frame_range=frame_range, name=name)
    written = _write_on(row, obj, clip, name, rigmap.bone_map_of(owner) if rigmap.across_rigs(obj, owner) else None)
    row.on_armature = written.name
    return written


def _write_on(row, obj, clip, name, bone_map=None):
    """A new action of ``clip`` on ``obj`` (through ``bone_map`` onto another rig, the bones without a
    counterpart listed in ``row.kept``), remembered on the row."""
    if bone_map is not None:
        written, kept = retarget.action_on_armature(clip, bone_map, obj, _on_name(name, obj))
        row.kept = ", ".join(kept)
    else:
        written = scene_motion.write_motion(clip, obj, name=name)
    _remember(row, written)
    return written


def _file_clip(settings, row):
    """The clip of a folder result, read as the search read it (skeleton, crop)."""
    asf = bpy.path.abspath(settings.asf.strip()) if settings.asf.strip() else None
    loaded = sources.read(sources.ClipSpec.parse(row.spec or row.source, asf=asf))
    clip = next((c for c in loaded if c.name == row.clip_name), loaded[0])
    if settings.crop_start and clip.frame_end >= settings.crop_start:
        clip = clip.crop(start=settings.crop_start, clamp=True)  # the library's crop start, as the search read it
    return clip


def window_action(settings, obj, row):
    """The action of a moment: frames ``row.frame_first..frame_last`` (the clip's own numbers) of the result,
    written once as a new action on ``obj`` (named ``NAME[first-last]``) and remembered in ``row.window_action``;
    the source action is only read."""
    got = bpy.data.actions.get(row.window_action) if row.window_action else None
    if got is not None:
        check_action(row, got)
        return got
    first, last = row.frame_first, row.frame_last
    source = bpy.data.actions.get(row.source) if row.is_action else None
    if source is not None:
        check_action(row, source)
        action = _on_obj(row, obj, source, frame_range=(first, last), name=f"{source.name}[{first}-{last}]")
        row.window_action = action.name
        return action
    elif row.is_action and not row.spec:
        raise ShapeSigError(f"the action {row.source!r} no longer exists")
    else:
        _check_file(row)
        clip = _file_clip(settings, row).crop(first, last)
        name = f"{clip.name}[{first}-{last}]"
    action = _write_on(row, obj, clip, name, "auto" if retarget.needs_retarget(clip, obj) else None)
    row.window_action = action.name
    return action


def explain_result(context, settings):
    """Why the selected result differs from the query (``core.elastic.explain.explain_clips``, on its window for a
    moment): stored as JSON in ``row.explain``; returns the explanation."""
    from ..core.elastic.explain import explain_clips

    library.check_problem(library.result_problem(context, settings))
    obj, _action, q = library.query_item(context, settings)
    row = results_of().results[results_of().results_index]
    action = bpy.data.actions.get(row.source) if row.is_action else None
    if action is not None:
        check_action(row, action)
        item = library.action_item(action, obj)
    else:
        _check_file(row)
        item = next((it for it in library.library_items(context, settings, obj)
                     if row.spec in (it.source, f"{it.source}#{row.clip_name}")), None)
        if item is None:
            raise ShapeSigError(f"the result {row.label or row.name!r} is no longer in the library")
    clips = item.clips()
    clip = next((c for c in clips if c.name == row.clip_name), clips[0])
    window = (row.frame_first, row.frame_last) if row.frame_last else None
    out = explain_clips(q.clips()[0], clip, window, depth=settings.depth)
    row.explain = json.dumps(out)
    _why_pictures(context, row, q, item, out.get("warp"))
    return out


def _why_pictures(context, row, query_item, item, warp):
    """Both clips' strips aligned by the warp for the Why Different box (none for clips without key points)."""
    from . import thumbnails

    row.why_query_path = row.why_result_path = ""
    if not warp:
        return
    try:
        row.why_query_path, row.why_result_path = thumbnails.why_pictures(
            library.get_cache(context), query_item, item, row.clip_name, warp, thumbnails.window_fraction(row))
    except (ShapeSigError, OSError):
        pass  # the explanation stands without pictures


def start_preview(context, settings, obj, action, written=""):
    """Play ``action`` on ``obj`` until ``stop_preview``, which restores exactly what is here now: the active
    action and its slot, the pose bones' rotation modes, the scene frame, whether the armature had animation
    data. The previous action is kept alive meanwhile (a fake user when nothing else uses it, taken back at Stop)
    so that saving during a preview loses nothing. ``written``: the action was written for the preview (a folder
    result) and is removed at Stop unless assigned."""
    ad = obj.animation_data
    current = ad.action if ad is not None else None
    slot = compat.object_action_slot(obj) if current is not None else None
    settings.preview_object = obj.name
    settings.preview_action = current.name if current is not None else ""
    settings.preview_slot = getattr(slot, "identifier", "") if slot is not None else ""
    settings.preview_modes = json.dumps({pb.name: pb.rotation_mode for pb in obj.pose.bones})
    settings.preview_frame = context.scene.frame_current
    settings.preview_animdata = ad is not None
    settings.preview_written = written
    settings.preview_fake_user = bool(current is not None and not current.use_fake_user and current.users <= 1)
    if settings.preview_fake_user:
        current.use_fake_user = True
    action_io.assign_action(obj, action, keep_previous=False)  # bones switch to the modes it has curves for
    context.scene.frame_set(int(action.frame_range[0]))
    screen = getattr(context, "screen", None)
    if screen is not None and context.window is not None and not screen.is_animation_playing:
        bpy.ops.screen.animation_play()


def _restore_slot(obj, identifier):
    ad = obj.animation_data
    if not identifier or ad is None or ad.action is None or not hasattr(ad, "action_slot"):
        return
    slot = next((sl for sl in ad.action.slots if sl.identifier == identifier), None)
    if slot is not None and ad.action_slot != slot:
        ad.action_slot = slot


def stop_preview(context, settings, keep=""):
    """End the preview: the armature gets back its action, slot, rotation modes and frame; the previous action
    its fake-user state; the action written for the preview is removed unless it is ``keep`` (being assigned)."""
    screen = getattr(context, "screen", None)
    if screen is not None and screen.is_animation_playing:
        bpy.ops.screen.animation_cancel(restore_frame=False)
    obj = bpy.data.objects.get(settings.preview_object)
    previous = bpy.data.actions.get(settings.preview_action) if settings.preview_action else None
    if obj is not None:
        if settings.preview_animdata or previous is not None:
            compat.assign_action(obj, previous)
            _restore_slot(obj, settings.preview_slot)
        elif obj.animation_data is not None:
            obj.animation_data_clear()
        modes = json.loads(settings.preview_modes) if settings.preview_modes else {}
        for pb in obj.pose.bones:
            if pb.name in modes and pb.rotation_mode != modes[pb.name]:
                pb.rotation_mode = modes[pb.name]
    if previous is not None and settings.preview_fake_user:
        previous.use_fake_user = False
    written = bpy.data.actions.get(settings.preview_written) if settings.preview_written else None
    if written is not None and settings.preview_written != keep:
        _forget_written(settings.preview_written)
        compat.remove_action(written)
    context.scene.frame_set(settings.preview_frame)
    settings.preview_object = settings.preview_action = settings.preview_slot = ""
    settings.preview_modes = settings.preview_written = ""
    settings.preview_fake_user, settings.preview_animdata = False, True


def _forget_written(name):
    """Result rows that named an action written for a preview point back at their file."""
    for row in results_of().results:
        if row.window_action == name:
            row.window_action = ""
        if row.on_armature == name:
            row.on_armature = ""
        if row.is_action and row.source == name and row.spec:
            row.is_action, row.source = False, row.spec


def preview_result(context, settings):
    """Start previewing the selected result (a folder clip is written as an action for the preview); returns
    the action."""
    library.check_problem(library.result_problem(context, settings))
    before = set(bpy.data.actions.keys())
    obj, action = selected_action(context, settings)
    # written for the preview (a folder clip, a moment's window, another rig's motion): removed at Stop
    start_preview(context, settings, obj, action, written="" if action.name in before else action.name)
    return action


def assign_result(context, settings):
    """Make the selected result the armature's action (a running preview is stopped first, keeping the result
    when it was written for the preview); the replaced action is stashed when nothing else uses it. Returns
    (armature, action, note): ``note`` one line when the query's frame range was reset, else ''."""
    library.check_problem(library.result_problem(context, settings))
    if settings.preview_object:
        row = results_of().results[results_of().results_index]
        keep = row.window_action if row.frame_last else (row.on_armature or (row.source if row.is_action else ""))
        stop_preview(context, settings, keep=keep)
    obj, action = selected_action(context, settings)
    before = obj.animation_data.action if obj.animation_data else None
    action_io.assign_action(obj, action)
    return obj, action, _release_query_range(settings, before, action)


def _release_query_range(settings, before, action):
    """The query's frame range belongs to the action it was set on: when Assign makes another action the query (the
    armature's, no Query Action chosen), the range is reset to the whole action (a range outside the new action's
    frames greyed Find Similar out). Returns one line saying so, or ''."""
    if settings.query_action or not settings.use_frame_range or before == action:
        return ""
    settings.use_frame_range, settings.frame_start, settings.frame_end = False, 0, 0
    return f"the query is now all of {action.name!r} (its frame range was for {before.name!r})" if before else ""


def take_moments(rows, index):
    """The indices of the result rows that are moments of the same take as row ``index`` (Moments lists every
    occurrence in a take), in the take's frame order; [] when that row is not a moment."""
    if not 0 <= index < len(rows) or not rows[index].frame_last:
        return []
    same = [i for i, r in enumerate(rows) if r.frame_last and r.source == rows[index].source]
    return sorted(same, key=lambda i: (rows[i].frame_first, i))


def moment_problem(context, settings):
    """Why the panel cannot step to another moment of the selected result's take, in one line, or None."""
    problem = library.result_problem(context, settings)
    if problem is not None:
        return problem
    res = results_of()
    order = take_moments(res.results, res.results_index)
    if not order:
        return f"the selected result is a whole clip, not a moment (tick {ENGINES['moments'].label} and search again)"
    if len(order) < 2:
        return "the selected moment is the only one found in its take"
    return None


def step_moment(context, settings, step):
    """Select the next (``step`` 1) or previous (-1) moment of the selected result's take along its timeline
    (frame order, round from the last to the first); a running preview plays it instead. Returns (row, its place,
    the take's moments)."""
    library.check_problem(moment_problem(context, settings))
    res = results_of()
    order = take_moments(res.results, res.results_index)
    place = (order.index(res.results_index) + step) % len(order)
    playing = bool(settings.preview_object)
    if playing:
        stop_preview(context, settings)
    res.results_index = order[place]
    if playing:
        preview_result(context, settings)
    return res.results[order[place]], place + 1, len(order)
