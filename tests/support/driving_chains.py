"""Hand-written cause chains for the six ego behaviors (three feasible each) and impossible ones."""

from __future__ import annotations

from regen.core import Behavior, CausePath, PathEntity

TEXT = {
    "drive_forward": "the ego-vehicle drives forward from stationary",
    "slow_down": "the ego-vehicle slows down",
    "stop_abruptly": "the ego-vehicle stops abruptly while driving forward",
    "stop_after_turn": "the ego-vehicle stops abruptly after a turn",
    "stop_in_intersection": "the ego-vehicle stops abruptly in an intersection",
    "change_lane": "the ego-vehicle changes lanes while driving forward",
}


def chain(template: str, cause: str, *entities: tuple[str, dict[str, list[str]]]) -> CausePath:
    events = [cause, TEXT[template]]
    return CausePath(behavior=Behavior(text=TEXT[template], domain="driving", params={"ego_template": template}),
                     events=events,
                     entities=[PathEntity(asset=a, event=cause, properties=p) for a, p in entities])


FEASIBLE: dict[str, list[CausePath]] = {
    "stop_abruptly": [
        chain("stop_abruptly", "a child runs across the road",
              ("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})),
        chain("stop_abruptly", "an ambulance with its siren on approaches from behind",
              ("ambulance", {"behavior": ["drive_forward"], "siren": ["on"], "target_speed": ["fast"],
                             "start_location": ["behind the ego-vehicle on adjacent lane"]})),
        chain("stop_abruptly", "the car in front brakes hard",
              ("sedan", {"behavior": ["brake_ahead"], "start_location": ["ahead_same_lane"],
                         "target_speed": ["moderate"]})),
        chain("stop_abruptly", "a parked car opens its door",
              ("parked_car", {"door": ["opens"], "start_location": ["roadside_ahead"]})),
        chain("stop_abruptly", "a police checkpoint is ahead",
              ("police_car", {"behavior": ["checkpoint"], "start_location": ["ahead_same_lane"]})),
        chain("stop_abruptly", "a road worker crosses the road",
              ("road_worker", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})),
        chain("stop_abruptly", "a car drives the wrong way in the ego's lane",
              ("sedan", {"behavior": ["wrong_way"], "start_location": ["ahead_same_lane"],
                         "target_speed": ["moderate"]})),
        chain("stop_abruptly", "the truck ahead stops abruptly", ("truck", {"behavior": ["brake_ahead"]})),
        chain("stop_abruptly", "the traffic light at the junction malfunctions",
              ("traffic_light", {"light_state": ["off"]})),
        chain("stop_abruptly", "an elderly man walks slowly across the road",
              ("adult", {"behavior": ["cross_the_road"], "target_speed": ["slow"]})),
    ],
    "slow_down": [
        chain("slow_down", "a slow truck is ahead", ("truck", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
        chain("slow_down", "a pedestrian group crosses far ahead", ("pedestrian_group",
              {"behavior": ["cross_the_road"], "start_location": ["crosswalk_ahead"]})),
        chain("slow_down", "a car cuts in", ("sedan", {"behavior": ["cut_in"],
              "start_location": ["behind_adjacent_lane"], "target_speed": ["fast"]})),
        chain("slow_down", "the car ahead pulls over to pick up a passenger", ("sedan",
              {"behavior": ["pull_over"], "start_location": ["ahead_same_lane"], "target_speed": ["moderate"]})),
        chain("slow_down", "traffic congestion ahead", ("traffic_queue", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
        chain("slow_down", "a tow truck pulls over ahead", ("tow_truck",
              {"behavior": ["pull_over"], "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
        chain("slow_down", "a person waits at the curb to hail a taxi", ("adult",
              {"behavior": ["wait_at_curb"], "start_location": ["roadside_ahead"]})),
        chain("slow_down", "the car ahead brakes suddenly", ("sedan", {"behavior": ["brake_ahead"]})),
    ],
    "drive_forward": [
        chain("drive_forward", "the traffic light turns green",
              ("traffic_light", {"light_state": ["red"]})),
        chain("drive_forward", "the car ahead departs", ("suv", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["fast"]})),
        chain("drive_forward", "pedestrians finish crossing", ("adult", {"behavior": ["cross_the_road"],
              "start_location": ["crosswalk_ahead"], "target_speed": ["fast"]})),
    ],
    "change_lane": [
        chain("change_lane", "a slow bus is ahead", ("bus", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
        chain("change_lane", "debris lies in the lane", ("debris", {"start_location": ["ahead_same_lane"]})),
        chain("change_lane", "a cyclist rides ahead", ("bicycle", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
    ],
    "stop_after_turn": [
        chain("stop_after_turn", "a pedestrian crosses the side road",
              ("adult", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})),
        chain("stop_after_turn", "a box lies on the road", ("box", {"start_location": ["ahead_same_lane"]})),
        chain("stop_after_turn", "the car ahead brakes", ("sedan", {"behavior": ["drive_forward"],
              "start_location": ["ahead_same_lane"], "target_speed": ["moderate"]})),
    ],
    "stop_in_intersection": [
        chain("stop_in_intersection", "a car runs the red light", ("sedan", {"behavior": ["run_red_light"],
              "start_location": ["junction_cross_street"], "target_speed": ["moderate"]})),
        chain("stop_in_intersection", "an oncoming car turns left across", ("suv", {"behavior": ["turn_left"],
              "start_location": ["junction_oncoming"], "target_speed": ["slow"]})),
        chain("stop_in_intersection", "a fire truck crosses with its siren on", ("fire_truck",
              {"behavior": ["run_red_light"], "siren": ["on"], "start_location": ["junction_cross_street"],
               "target_speed": ["moderate"]})),
        chain("stop_in_intersection", "an ambulance with its siren on passes through the junction",
              ("ambulance", {"behavior": ["pass_through"], "start_location": ["junction_cross_street"],
                             "target_speed": ["fast"]})),
    ],
}

IMPOSSIBLE: dict[str, CausePath] = {
    # the lead must brake ahead of the ego yet is slower than the ego: no placement exists
    "slow_lead_brakes": chain("stop_abruptly", "a slow car in front brakes", ("sedan", {
        "behavior": ["drive_forward"], "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})),
    # a one-lane junction road cannot host a vehicle in the adjacent lane
    "no_adjacent_lane": chain("stop_in_intersection", "an ambulance overtakes", ("ambulance", {
        "behavior": ["drive_forward"], "start_location": ["behind_adjacent_lane"]})),
    "contradictory": chain("stop_abruptly", "an ambulance approaches", ("ambulance", {
        "siren": ["on", "off"], "behavior": ["drive_forward"], "start_location": ["behind_adjacent_lane"]})),
    "unsupported_behavior": chain("stop_abruptly", "debris drives", ("debris", {"behavior": ["drive_forward"]})),
}


def verified_run(tmp_path_factory, scenarios: dict[str, CausePath]):
    """A run folder whose scenarios (folder name -> chain) all verified through the main job's
    stages (rule-based grounding, no pictures), in a model cache of its own; yields its path."""
    import pytest

    from regen.pipeline import run_path
    from regen.runfolder import RunFolder

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        run = tmp_path_factory.mktemp("run")
        for name, path in scenarios.items():
            out = run_path(path, run / RunFolder.SCENARIOS / name, pictures=False)
            assert out.verdict.feasible, out.verdict.reason
        yield run


def chain_simulator(key: str, i: int):
    """A function of no argument that simulates ``FEASIBLE[key][i]`` (rule-based grounding, seed
    0) on Scenic, compiled again at each call (not the program kept from the call before); its
    RawRun."""
    from regen.driving.grounding.rules import ground_rule_based
    from regen.driving.simulation import run as run_module
    from regen.driving.simulation.scenario import scenic_program, timing

    scenario = ground_rule_based(FEASIBLE[key][i], seed=0)
    text = scenic_program(scenario)
    dt, steps, seed = timing(scenario)

    def simulate():
        run_module._RECENT.clear()
        return run_module.run_program(text, steps=steps, dt=dt, seed=seed)

    return simulate
