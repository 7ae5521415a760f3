"""Rigs, one module a job: ``names`` (the canonical joint set ``JOINTS``, the built-in bone-name tables
``FAMILIES``), ``detect`` (automatic maps from names, hierarchy and rest pose: ``analyse_rig``, ``detect_map``),
``maps`` (a valid ``{bone: joint}`` map and saved maps, in the file format of ``core.io.bone_map_file``),
``space`` (the comparison space across rigs: ``to_comparison_space``, ``apply_bone_map``, ``resolve_map``),
``retarget`` (back onto a rig: ``onto_rig``, ``rest_retarget``), ``chains`` (bones between written joints) and
``coverage`` (joints and limb chains compared, ``MIN_COVERAGE``); ``body`` (the canonical body posed like a clip,
the local search's key points) is imported from its module. The package re-exports the others' public names. See
docs/rigs.md and docs/model.md, "Comparison space across rigs".
"""

from .chains import chains_between, share_chains
from .coverage import (MIN_COVERAGE, below_minimum, chains_covered, coverage, coverage_from, coverage_report,
                       joint_coverage, moving_count)
from .detect import LIMB_CHAINS, RigReport, analyse_rig, detect_map
from .maps import BONE_MAP_MODES, MAX_MAP_BYTES, check_map, load_map, map_json, parse_map, save_map
from .names import BODY, CANONICAL_PARENTS, FAMILIES, JOINTS, LIMBS, SIDES, detect_family, strip_prefix
from .retarget import REST_DEGREES, onto_rig, other_rigs, rest_retarget, rests_differ
from .space import (TABLES_VERSION, TRAVEL_RATIO, analyse_clip, apply_bone_map, check_comparable, clip_heading,
                    heading, hips_path, leg_length, resolve_map, rest_forward, to_comparison_space, world_rotations)

__all__ = [
    "JOINTS", "BODY", "LIMBS", "SIDES", "FAMILIES", "BONE_MAP_MODES", "strip_prefix", "detect_map", "detect_family",
    "analyse_rig", "analyse_clip", "RigReport", "LIMB_CHAINS", "chains_covered", "joint_coverage", "coverage_report",
    "coverage_from", "below_minimum",
    "check_map", "parse_map", "load_map", "save_map", "map_json", "MAX_MAP_BYTES", "resolve_map", "world_rotations",
    "heading", "clip_heading", "rest_forward",
    "to_comparison_space", "rest_retarget", "rests_differ", "other_rigs", "REST_DEGREES", "apply_bone_map",
    "check_comparable", "coverage", "moving_count", "onto_rig",
    "MIN_COVERAGE", "TABLES_VERSION", "TRAVEL_RATIO", "CANONICAL_PARENTS",
]
