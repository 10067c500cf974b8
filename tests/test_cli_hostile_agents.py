"""Hostile saved agents and plug-ins, as users meet them through the real ``anonloc`` script
(issue 26): a stale store after an edited ``config.json``, garbage or oversized members, a bad
``config.json``, and policy plug-ins that raise, shadow a built-in or claim a name twice."""

from __future__ import annotations

import json
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from tests.cli_helpers import SCRIPT, read_csv, run_script, script_env

pytest.importorskip("stable_baselines3")

from agents.linear_agent import linear_weights, save_linear_agent
from agents.linear_terms import LINEAR_TERMS
from agents.policy import BUNDLED

#: The documented limit of a saved agent's ``data`` member (docs/cli.md; agents.saved_agent).
DATA_LIMIT = 16 << 20

#: A short evaluation: 1 episode of 3 pictures.
SHORT = ("--seeds", "1", "--pictures", "3", "--workers", "1")


def _without_spec(tmp_path: Path) -> Path:
    """An agent saved before specs existed: the linear scorer's 18 terms (the bundled agent's
    weights for them), with no spec in its ``policy_kwargs``; its run folder's ``config.json``
    then decides its condition."""
    weights = linear_weights("bundled")
    older = save_linear_agent(
        np.array([weights[t.name] for t in LINEAR_TERMS]), tmp_path / "older.zip"
    )
    with zipfile.ZipFile(older) as source:
        data = json.loads(source.read("data"))
    data["policy_kwargs"].pop("spec", None)
    return _rewritten(tmp_path, "nospec.zip", "data", json.dumps(data).encode(), older)


def _run_folder(tmp_path: Path, train: object) -> Path:
    run = tmp_path / "r"
    run.mkdir(exist_ok=True)
    shutil.copy(_without_spec(tmp_path), run / "agent.zip")
    (run / "config.json").write_text(json.dumps({"train": train}))
    return run


def _rewritten(tmp_path: Path, name: str, member: str, data: bytes, agent: Path = BUNDLED) -> Path:
    """``agent`` (the bundled one) with ``member`` replaced by ``data``."""
    path = tmp_path / name
    with zipfile.ZipFile(agent) as source, zipfile.ZipFile(path, "w") as target:
        for info in source.infolist():
            body = data if info.filename == member else source.read(info.filename)
            target.writestr(info.filename, body, compress_type=zipfile.ZIP_DEFLATED)
    return path


def _eval(agent: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return run_script("eval", "--agent", agent, "--scenario", "default", *SHORT, "--out", out,
                      *extra)  # fmt: skip


@pytest.mark.slow  # two evaluations: about 20 s on 2 idle cores
def test_eval_runs_again_when_the_runs_recorded_condition_changes(tmp_path: Path) -> None:
    run = _run_folder(tmp_path, {"condition": "free"})
    out = tmp_path / "s.csv"
    first = _eval(run, out, "-q")
    assert first.returncode == 0, first.stderr
    free = out.read_text()
    (run / "config.json").write_text(json.dumps({"train": {"condition": "swarm"}}))
    second = _eval(run, out, "-q")
    assert second.returncode == 0, second.stderr
    assert "(1 episodes executed, 0 reused)" in second.stdout, second.stdout  # not 0 executed
    assert out.read_text() != free  # swarm duty moves the robots otherwise
    assert read_csv(out)[0]["policy"] == "agent"


def test_eval_output_has_one_label_and_counts_pictures_one_way(tmp_path: Path) -> None:
    out = tmp_path / "e.csv"
    done = _eval(BUNDLED, out)
    assert done.returncode == 0, done.stderr
    assert "eval: success at each robot's first decision" in done.stdout
    assert "bench" not in done.stdout + done.stderr  # the progress line too
    rows = read_csv(out)
    correct = np.array([json.loads(r["correct_by_picture"]) for r in rows])
    first_all = int(np.flatnonzero(correct.all(axis=0))[0])  # 0: the picture at reset
    shown = out.with_suffix(".md").read_text().split("## Pictures until 99 %")[1]
    row = next(line for line in shown.splitlines() if line.startswith("| agent |"))
    censored_mean = row.split(" | ")[4]
    # pictures seen, the one at reset counted as 1: as "pictures to decision" counts
    assert censored_mean.startswith(f"{first_all + 1:.3g} "), (row, first_all)
    assert min(int(r["pictures_to_decision"]) for r in rows) >= 1


def test_a_garbage_weights_member_is_one_message_naming_it_without_unsafe_advice(
    tmp_path: Path,
) -> None:
    agent = _rewritten(tmp_path, "agent.zip", "policy.pth", b"not a tensor file " * 50)
    done = _eval(agent, tmp_path / "g.csv")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert "member policy.pth is not readable PyTorch weights" in done.stderr
    assert str(agent) in done.stderr
    assert "weights_only=False" not in done.stderr
    assert len(done.stderr.strip().splitlines()) <= 2, done.stderr


def test_a_data_member_past_its_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    with zipfile.ZipFile(BUNDLED) as source:
        data = source.read("data")
    padded = data + b" " * (DATA_LIMIT + 1 - len(data))  # still valid JSON
    agent = _rewritten(tmp_path, "agent.zip", "data", padded)
    assert agent.stat().st_size < 2 << 20  # a small zip declaring a large member
    done = _eval(agent, tmp_path / "d.csv")
    assert done.returncode == 2, done.stderr
    assert "member data declares 16.0 MiB" in done.stderr
    assert "16.0 MiB a saved agent's member may hold" in done.stderr


def test_a_weights_member_declaring_a_gibibyte_is_refused_at_once(tmp_path: Path) -> None:
    from agents.policy import check_layout

    agent = _rewritten(tmp_path, "agent.zip", "policy.pth", b"\0" * 1000)
    raw = bytearray(agent.read_bytes())
    entry = raw.index(b"PK\x01\x02")  # the central directory's entries
    while raw[entry + 46 : entry + 56] != b"policy.pth":
        entry = raw.index(b"PK\x01\x02", entry + 4)
    raw[entry + 24 : entry + 28] = (1 << 30).to_bytes(4, "little")  # declared uncompressed size
    agent.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"member policy.pth declares 1024.0 MiB, more than the "):
        check_layout(agent)


@pytest.mark.parametrize(
    ("train", "expected"),
    [
        (5, "'train' must be an object"),
        ({"condition": "sideways"}, "train.condition must be one of"),
        ({"budget": "lots"}, "train.budget must be a number in [0, 1]"),
    ],
)
def test_a_bad_config_json_is_a_message_naming_the_file(
    tmp_path: Path, train: object, expected: str
) -> None:
    run = _run_folder(tmp_path, train)
    done = _eval(run, tmp_path / "c.csv")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert str(run / "config.json") in done.stderr
    assert expected in done.stderr


# -- policy plug-ins -----------------------------------------------------------------------

_WORKING = (
    "from baselines.localizers import BayesLocalizer\n"
    "from baselines.excitations import Still\n"
    "from baselines.policies import Team\n\n"
    "def team(config, n, mode, excitation, **kwargs):\n"
    "    return Team(config, BayesLocalizer(config, n, mode, **kwargs), Still())\n"
)


def _plugin(root: Path, dist: str, entries: dict[str, str], module: str, code: str) -> None:
    info = root / f"{dist.replace('-', '_')}-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entries.items())
    (info / "entry_points.txt").write_text(f"[anonloc.policies]\n{lines}")
    (root / f"{module}.py").write_text(code)


def _bench(root: Path, policy: str, out: Path) -> subprocess.CompletedProcess[str]:
    env = script_env()
    env["PYTHONPATH"] = f"{env['PYTHONPATH']}:{root}"
    return subprocess.run(
        [str(SCRIPT), "bench", "--scenario", "default", "--policy", policy, "--seeds", "1",
         "--pictures", "2", "--workers", "1", "-q", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=180,
    )  # fmt: skip


def test_a_plugin_that_raises_at_import_is_one_message_naming_it(tmp_path: Path) -> None:
    _plugin(tmp_path, "boom-plugin", {"boom": "plugin_boom:team"}, "plugin_boom",
            "raise RuntimeError('the licence server is down')\n")  # fmt: skip
    done = _bench(tmp_path, "boom", tmp_path / "b.csv")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert "boom = 'plugin_boom:team' (from boom-plugin)" in done.stderr
    assert "RuntimeError: the licence server is down" in done.stderr
    assert not (tmp_path / "b.csv").exists()


def test_a_plugin_shadowing_a_builtin_name_is_reported_and_the_builtin_runs(
    tmp_path: Path,
) -> None:
    _plugin(tmp_path, "shadow-plugin", {"bayes": "plugin_shadow:team"}, "plugin_shadow",
            "raise RuntimeError('never imported')\n")  # fmt: skip
    done = _bench(tmp_path, "bayes", tmp_path / "b.csv")
    assert done.returncode == 0, done.stderr
    assert "policy 'bayes' is built in; the plug-in bayes = 'plugin_shadow:team'" in done.stderr


def test_two_plugins_claiming_one_name_say_which_one_is_used(tmp_path: Path) -> None:
    _plugin(tmp_path, "alpha-plugin", {"twin": "plugin_alpha:team"}, "plugin_alpha", _WORKING)
    _plugin(tmp_path, "beta-plugin", {"twin": "plugin_beta:team"}, "plugin_beta",
            "raise RuntimeError('beta must not be imported')\n")  # fmt: skip
    done = _bench(tmp_path, "twin", tmp_path / "b.csv")
    assert done.returncode == 0, done.stderr
    assert "claimed by 2 plug-ins: twin = 'plugin_alpha:team' (from alpha-plugin) is used" in (
        done.stderr
    )
    assert "ignored: twin = 'plugin_beta:team' (from beta-plugin)" in done.stderr


def test_anonlocs_own_agent_wins_over_a_plugin_of_the_same_name(tmp_path: Path) -> None:
    from baselines.catalog import plugin_notes  # type: ignore[attr-defined,unused-ignore]

    _plugin(tmp_path, "aaa-plugin", {"agent": "plugin_aaa:team"}, "plugin_aaa", _WORKING)
    code = "from baselines.catalog import plugin_notes; print(plugin_notes(['agent']))"
    env = script_env()
    env["PYTHONPATH"] = f"{env['PYTHONPATH']}:{tmp_path}"
    import sys

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert "'agents.policy:team' (from anonloc) is used" in done.stdout, done.stderr
    assert plugin_notes(["agent"]) == []  # without the plug-in: one claim, nothing to say
