"""Config dataclasses and overrides: every bad value is refused with a message naming it."""

from __future__ import annotations

import dataclasses

import pytest

import anonloc_env
from anonloc_env import CameraConfig, EnvConfig, RobotConfig, ScheduleConfig


def test_presets_exist_and_differ_from_each_other_where_expected() -> None:
    assert set(anonloc_env.preset_names()) >= {
        "default",
        "paper-angular",
        "paper-linear",
        "paper-motion",
    }
    paper = anonloc_env.make_config("paper-motion")
    assert paper.n_robots == 2
    assert paper.dt == 0.01
    assert paper.picture_interval == 10.0
    assert paper.robot.shape == "square"


def test_overrides_apply_on_top_of_the_preset_and_nested_dicts_change_only_named_fields() -> None:
    base = anonloc_env.make_config("paper-linear")
    config = anonloc_env.make_config(
        "paper-linear", n_robots=5, picture_interval=2.0, camera={"pixel_noise": 3.0}
    )
    assert config.n_robots == 5
    assert config.schedule.picture_interval == 2.0
    assert config.camera.pixel_noise == 3.0
    assert config.camera.scale == base.camera.scale  # untouched field kept from the preset
    assert config.robot == base.robot


def test_section_can_be_a_dataclass() -> None:
    robot = RobotConfig(shape="circle", size=0.1)
    env = anonloc_env.parallel_env(robot=robot)
    assert env.config.robot is robot


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_robot": 3}, "unknown override 'n_robot' (did you mean 'n_robots'?)"),
        ({"camera": {"pixel_nois": 1.0}}, "unknown field camera.pixel_nois"),
        ({"robot": {"shape": "triangle"}}, "robot.shape must be one of"),
        ({"n_robots": 0}, "n_robots must be in [1, 100000]"),
        ({"dt": -0.1}, "dt must be in (0, 10]"),
        ({"dt": float("nan")}, "dt must be a finite number"),
        ({"max_cycles": 0}, "max_cycles must be in [1, 1e+06]"),
        ({"arena_size": (4.0,)}, "arena_size must be a pair"),
        ({"arena_size": (4.0, -1.0)}, "arena_size[1] must be in (0, 1e+06]"),
        ({"camera": {"p_miss": 1.0}}, "camera.p_miss must be in [0, 1)"),
        ({"camera": {"pixel_noise": -1.0}}, "camera.pixel_noise must be in [0, 1e+06]"),
        ({"camera": {"tilt_deg": 90.0}}, "camera.tilt_deg must be in (-80, 80)"),
        ({"camera": {"false_positives": -0.5}}, "camera.false_positives must be in [0, 1000]"),
        ({"camera": {"orientation": "yes"}}, "camera.orientation must be True or False"),
        ({"robot": {"v_max": 0.0}}, "robot.v_max must be in (0, 1e+06]"),
        ({"robot": {"odometry_noise": 1.5}}, "robot.odometry_noise must be in [0, 1)"),
        ({"schedule": {"jitter": 0.6}}, "schedule.jitter must be in [0, 0.5)"),
        ({"schedule": {"blackouts": [(5.0, 2.0)]}}, "schedule.blackouts[0] must have end > start"),
        ({"picture_interval": 0.01, "dt": 0.05}, "picture_interval must be >= dt"),
        ({"n_robots": 500, "arena_size": (2.0, 2.0)}, "holds at most"),
        ({"camera": {"tilt_deg": 60.0, "height": 1.5}}, "camera.height must exceed"),
        ({"observation": {"history": 65}}, "observation.history must be in [0, 64]"),
        ({"observation": {"max_detections": 2}}, "observation.max_detections must be in"),
        ({"n_robots": 2.5}, "n_robots must be an integer"),
        ({"camera": {"scale": float("inf")}}, "camera.scale must be a finite number"),
        ({"robot": {"v_max": float("inf")}}, "robot.v_max must be a finite number"),
    ],
)
def test_bad_config_is_refused_with_a_clear_message(kwargs: dict, message: str) -> None:
    with pytest.raises((ValueError, TypeError)) as error:
        anonloc_env.parallel_env(**kwargs)
    assert message in str(error.value)


def test_unknown_preset_lists_the_valid_ones() -> None:
    with pytest.raises(ValueError, match="valid: \\['default'"):
        anonloc_env.parallel_env("paper-angle")


def test_section_of_wrong_type_is_refused() -> None:
    with pytest.raises(TypeError, match="camera must be a dict of fields or a CameraConfig"):
        anonloc_env.parallel_env(camera=3)
    with pytest.raises(TypeError, match="robot must be a RobotConfig"):
        EnvConfig(robot=CameraConfig())  # type: ignore[arg-type]  # deliberately wrong


def test_configs_are_frozen() -> None:
    config = anonloc_env.make_config()
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.n_robots = 7  # type: ignore[misc]  # deliberately forbidden


def test_lists_are_normalised_to_tuples() -> None:
    schedule = ScheduleConfig(blackouts=[[1, 2]])  # type: ignore[list-item]  # lists accepted
    assert schedule.blackouts == ((1.0, 2.0),)
    assert EnvConfig(arena_size=[5, 6]).arena_size == (5.0, 6.0)  # type: ignore[arg-type]


def test_same_field_given_twice_with_different_values_is_an_error() -> None:
    with pytest.raises(ValueError, match=r"schedule\.picture_interval is given twice"):
        anonloc_env.make_config(picture_interval=2.0, schedule={"picture_interval": 3.0})
