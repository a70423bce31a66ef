"""fuzzynav's crisp parameters: their defaults, tuning bounds and the shipped file
(read by :func:`load_params`, written by :func:`write_params`).

Apart from :mod:`fuzzynav.controller.navigator.controller` so that the parts table
(:mod:`fuzzynav.controller.navigator.parts`), which names these parameters, and the
controller, which uses the parts table, import in one direction only.
"""

from __future__ import annotations

from pathlib import Path

from fuzzynav.resources import asset_path

RULES_DIR = asset_path("rules")
GOAL_PATH = RULES_DIR / "fuzzynav_goal.toml"
AVOID_PATH = RULES_DIR / "fuzzynav_avoid.toml"
PARAMS_PATH = RULES_DIR / "fuzzynav_params.toml"

# The crisp parameters, their defaults (used when the file lacks a key) and tuning bounds.
CRISP_DEFAULTS: dict[str, float] = {
    "control_period_s": 0.02,  # the loop's period (the memory counts calls)
    "alpha_front_lo_m": 0.4,  # alpha = 1 when the front is nearer than this
    "alpha_front_hi_m": 1.2,  # alpha = 0 beyond this
    "alpha_side_lo_m": 0.25,
    "alpha_side_hi_m": 0.7,
    "alpha_side_max": 1.0,  # the side sectors alone never take full control
    "memory_grow_mps": 0.35,  # how fast a remembered distance grows back
    "side_fold_deg": 30.0,  # ideal: an obstacle this far off-axis counts as beside
    "latch_front_m": 2.5,  # choose and latch the side when the front is nearer
    "release_front_m": 3.0,  # release the latch when the front is farther
    "ttc_gain_s": 3.0,  # front distance shortened by closing speed x this
    "stall_s": 15.0,  # no progress for this long -> boundary following
    "stall_progress_m": 0.3,
    "leave_margin_m": 0.5,
    "follow_bias_rad": 0.25,  # virtual bearing pulls this far towards the boundary
    "follow_max_s": 60.0,
    "follow_lost_m": 2.0,  # nothing remembered this near: stop following
    "guard_m": 0.8,  # no goal turn towards a passed obstacle nearer than this
    "guard_speed_v": 6.0,  # ... and drives on at this speed
    "memory_s": 6.0,  # echoes are remembered this long
    "store_s": 0.2,  # one echo point per beam per store_s
    "sector_s": 0.04,  # remembered sectors recomputed at the sensors' 25 Hz
    "odo_lag": 0.06,
    "turn_lag": 0.5,  # the tracker's turn-rate lag per period (the plant's turn is fast)
    "arrive_m": 1.5,  # avoidance yields to the goal this near the target
    "memory_creep_mps": 0.0,  # remembered echoes count as nearer by this x their age
    "plan_margin_m": 0.3,  # the bearing planner passes remembered points this far off the flank
    "plan_horizon_m": 4.5,  # ... looking this far ahead
    "plan_nearest_m": 1.0,  # nearer points are left to the avoidance block
    "store_range_m": 4.0,  # echoes farther than this are not remembered
    "plan_switch_rad": 0.15,  # ... and before that changes side only for a detour this much shorter
    "plan_latch_m": 2.0,  # the planner's side is latched once points are this near
    "plan_flip_rad": 1.3,  # ... or, with points near, for a detour larger than this
    "plan_stuck_s": 6.0,  # no progress for this long: the robot is stuck, and then
    "plan_flip_hold_s": 15.0,  # ... keeps a new side at least this long (no dithering)
    "plan_flip_min_s": 2.0,  # near points: a side is kept at least this long
    "plan_turn_weight": 1.0,  # near points, all-around sensing: a new side also pays this x its bearing off the heading
    "front_corridor_m": 0.3,  # a remembered point ahead within the flanks + this is "front"
    "deadlock_s": 1.0,  # near-zero command this long -> turn on the spot this long
    "back_max_s": 1.5,  # longest continuous reversing (nothing looks backwards)
    "echo_spread_deg": 4.0,  # half the ultrasonic beam: an echo is remembered as an arc
    "merge_m": 0.15,  # an echo this near a remembered one replaces it
    "dodge_horizon_s": 3.0,  # a moving obstacle's closest approach is predicted this far (0 = off)
    "dodge_safe_m": 1.1,  # ... and kept at least this far (centre to centre)
    "dodge_radius_m": 0.25,  # the radius assumed to place an obstacle's centre
    "dodge_min_speed_mps": 0.08,  # slower obstacles are left to the avoidance block
    "dodge_sightings": 3,  # consistent sightings (store_s apart) before a speed is trusted
    "target_gate_m": 0.3,  # a target reading this far from the tracked target is doubted (0: off)
    "target_filter": 0.05,  # ... the tracked target follows agreeing readings by this per period
    "target_still_m": 0.05,  # ... a doubted reading that stays this near where it was first
    "target_settle_s": 0.5,  # ... for this long is the target, moved
}
# What `fuzzynav tune --controller fuzzynav` searches (the rest stays at the hand design).
CRISP_BOUNDS: dict[str, tuple[float, float]] = {
    "alpha_front_lo_m": (0.2, 0.8),
    "alpha_front_hi_m": (0.9, 2.0),
    "alpha_side_lo_m": (0.1, 0.5),
    "alpha_side_hi_m": (0.5, 1.2),
    "plan_margin_m": (0.15, 0.6),
    "plan_nearest_m": (0.5, 1.5),
    "echo_spread_deg": (0.0, 7.5),
    "ttc_gain_s": (0.0, 4.0),
    "arrive_m": (0.5, 2.5),
    "memory_s": (2.0, 8.0),
}


def load_params(path: str | Path = PARAMS_PATH) -> dict[str, float]:
    params = dict(CRISP_DEFAULTS)
    path = Path(path)
    if path.exists():
        from fuzzynav.resources import loads_user_toml, read_user_text

        data = loads_user_toml(read_user_text(path, "parameter file"), str(path))
        crisp = data.get("crisp", {})
        unknown = set(crisp) - set(CRISP_DEFAULTS)
        if unknown:
            raise ValueError(f"{path}: unknown crisp parameter(s) {sorted(unknown)}")
        params.update({k: float(v) for k, v in crisp.items()})
    return params


def params_toml(params: dict) -> str:
    """The crisp parameters as the ``[crisp]`` table of ``fuzzynav_params.toml``: plain
    data, written by tomli-w (in :data:`CRISP_DEFAULTS` order) under two comment lines."""
    import tomli_w

    header = (
        "# fuzzynav's crisp parameters (arbitration, memory, escape); see\n"
        "# controller/navigator/controller.py. Written by FuzzyNavTunable.save.\n\n"
    )
    return header + tomli_w.dumps({"crisp": {k: float(params[k]) for k in CRISP_DEFAULTS}})


def write_params(params: dict, path: str | Path = PARAMS_PATH) -> Path:
    path = Path(path)
    from fuzzynav.safe_files import write_text_atomically

    write_text_atomically(path, params_toml(params))
    return path
