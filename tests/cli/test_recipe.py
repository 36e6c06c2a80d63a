"""``occrl recipe``, ``occrl demos``: the default networks' recipe as commands. Its full size is what the
model cards record; its smoke size runs every step; the demonstrations equal the ``--lr 0`` training route."""

import json
import re
import shlex
from pathlib import Path

import pytest
import torch

from occrl.cli import main, make_parser
from occrl.cli.commands import train_overrides
from occrl.cli.recipe import STEP_RECORD
from occrl.cli.recipe_steps import RECIPES, recipe_steps
from occrl.pretrained import DEFAULT_NETWORKS, model_card
from occrl.training import TrainConfig, get_train_config
from occrl.training.dagger_buffer import DaggerBuffer
from occrl.training.demonstrations import demonstration_config

PARSER = make_parser()


def _train_config(argv: list[str]) -> tuple[TrainConfig, object]:
    """The settings and the parsed options of an ``occrl train`` command."""
    args = PARSER.parse_args(argv)
    return get_train_config(args.preset, **train_overrides(args)), args


def _demos_config(argv: list[str]) -> tuple[TrainConfig, object]:
    args = PARSER.parse_args(argv)
    settings = dict(teacher=args.teacher, teacher_search=args.teacher_search, action_noise=args.action_noise)
    config = demonstration_config(
        **settings, label_episodes=args.label_episodes, num_envs=args.num_envs, stage=args.stage, iterations=args.iterations
    )
    return config, args


def _beyond_preset(config: TrainConfig) -> dict:
    preset = get_train_config(config.preset).flat_settings()
    return {k: v for k, v in config.flat_settings().items() if preset[k] != v}


def _card_command(text: str) -> list[str]:
    """A card's recorded command as arguments of ``occrl`` (without its program and its run folder)."""
    words = shlex.split(re.sub(r"\s*\(.*\)$", "", text))
    return words[1:] if words[0] == "occrl" else words


@pytest.mark.parametrize("network", sorted(RECIPES))
def test_the_full_size_steps_are_the_settings_the_model_cards_record(network):
    steps = {s.name: s for s in recipe_steps(network, "full")}
    card = model_card(network)
    prefix = "noheatmap-" if "noheatmap" in network else ""
    # the warm start and the takeover: their networks' cards
    for name in (f"{prefix}warmstart", f"{prefix}takeover"):
        shipped = model_card(f"occnet-{name}")
        config, args = _train_config(list(steps[name].argv))
        assert (config.preset, args.seed, args.iterations) == (shipped["train_preset"], shipped["seed"], shipped["iterations"])
        beyond = {k: "occnet-takeover" if v == "{takeover}" else v for k, v in _beyond_preset(config).items()}  # the step's network
        assert beyond == shipped.get("settings_beyond_preset", {"heatmap": False} if prefix else {})
    assert "{warmstart}" in steps["takeover"].argv and f"{{{prefix}warmstart}}" in steps[f"{prefix}takeover"].argv
    if prefix:  # the acting planner on the full takeover network
        assert model_card("occnet-noheatmap-takeover")["settings_beyond_preset"]["teacher_weights"] == "occnet-takeover"
        assert "{takeover}" in steps["noheatmap-takeover"].argv
    # the demonstrations: the same settings as the card's --lr 0 training runs
    data9, data10, fit = card["recipe_before"]
    for name, recorded in (("demos-seed9", data9), ("demos-seed10", data10)):
        old, old_args = _train_config(_card_command(recorded["command"]))
        new, new_args = _demos_config([*steps[name].argv, "--out", "DIR"])
        assert new == old and (new_args.seed, new_args.iterations) == (old_args.seed, old_args.iterations)
        assert old_args.init_weights == "occnet-takeover" and new_args.init_weights == "{takeover}"
        assert recorded["frames"] == new.frames_per_batch * new_args.iterations
    # the fit: the card's command, whose network at step 3000 is the fit's end (a save at step N does not depend on the total)
    recorded = _card_command(fit["command"])
    assert recorded[:2] == ["python", "scripts/offline_imitation.py"] and card["init_weights"] == "weights_step3000.pt"
    args = PARSER.parse_args([*steps[f"{prefix}fit"].argv, "--out", "DIR"])
    assert args.data == ["{demos-seed9:dir}", "{demos-seed10:dir}"] and recorded[
        recorded.index("--data") + 1 : recorded.index("--data") + 3
    ] == ["DATA9", "DATA10"]
    assert args.init_weights == f"{{{prefix}takeover}}" and recorded[recorded.index("--init-weights") + 1] == f"occnet-{prefix}takeover"
    assert (args.steps, args.lr, args.save_every) == (
        3000,
        float(recorded[recorded.index("--lr") + 1]),
        int(recorded[recorded.index("--save-every") + 1]),
    )
    # the self-imitation: this card
    config, args = _train_config(list(steps[f"{prefix}selfimit"].argv))
    assert (config.preset, args.seed, args.iterations) == (card["train_preset"], card["seed"], card["iterations"])
    assert _beyond_preset(config) == card["settings_beyond_preset"] and args.init_weights == f"{{{prefix}fit}}"


@pytest.mark.parametrize("default", sorted(DEFAULT_NETWORKS))
def test_the_cards_total_the_recipe_from_scratch_and_name_what_was_not_measured(default):
    network = DEFAULT_NETWORKS[default]
    whole = model_card(network)["recipe_from_scratch"]
    assert whole["command"] == f"occrl recipe {default} --size full --run-dir DIR"
    assert [s["step"] for s in whole["steps"]] == [s.name for s in RECIPES[network]]
    known = [s["cpu_hours"] for s in whole["steps"] if s["cpu_hours"] is not None]
    assert whole["cpu_hours"] == round(sum(known), 2) and whole["cpu_hours_complete"] == (len(known) == len(whole["steps"]))
    for s in whole["steps"]:
        if s["from"].startswith("occnet-"):
            assert s["cpu_hours"] == model_card(s["from"])["cpu_hours"]
    fit = next(s for s in whole["steps"] if s["step"].endswith("fit"))
    assert fit["cpu_hours"] == model_card(network)["recipe_before"][2]["cpu_hours"]
    if fit["cpu_hours"] is None:
        assert "not logged" in fit["note"]


def test_list_prints_every_step_command_and_a_bad_name_is_refused(capsys):
    assert main(["recipe", "occnet", "--list"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n   occrl ") == len(RECIPES["occnet-selfimit"]) and "--run-dir RUN_DIR/warmstart" in out
    assert "occrl fit --data RUN_DIR/demos-seed9 RUN_DIR/demos-seed10 --init-weights RUN_DIR/takeover/weights.pt" in out
    assert main(["recipe", "occnet-ei", "--list"]) == 2
    assert "no recipe for 'occnet-ei'" in capsys.readouterr().err
    assert main(["recipe", "occnet"]) == 2 and "give --run-dir" in capsys.readouterr().err


DEMOS = ["--teacher-action-noise", "0.05", "--label-episodes", "success", "--num-envs", "2", "--init-weights", "occnet-takeover"]


@pytest.mark.integration
def test_demos_write_the_data_set_of_the_lr0_training_route_bit_for_bit(tmp_path):
    old, new = tmp_path / "old", tmp_path / "new"
    route = "train --preset cpu-curriculum --imitation-teacher clearing-observed --teacher-search hierarchical --imitation-beta-min 1 "
    route += "--critic-coeff 0 --heatmap-coeff 0 --collector single --replay-stage-workers 0 --start-stage 2 --promotion-eval-every 1000 "
    route += "--imitation-updates 1 --imitation-buffer-iters 1000 --lr 0 --iterations 2 --seed 9 --no-progress"
    assert main([*route.split(), *DEMOS, "--run-dir", str(old)]) == 0
    assert main(["demos", "--num-envs", "2", "--iterations", "2", "--seed", "9", "--no-progress", "--out", str(new)]) == 0
    saved = [torch.load(run / "checkpoint.pt", weights_only=False) for run in (old, new)]
    assert saved[0]["train_config"] == saved[1]["train_config"]
    buffers = []
    for run, checkpoint in zip((old, new), saved):
        buffer = DaggerBuffer(capacity=1)
        buffer.load(run / checkpoint["state"]["dagger_data"])
        buffers.append(buffer.batches)
    assert len(buffers[0]) == len(buffers[1]) == 2
    for a, b in zip(*buffers):
        assert set(a.keys(True, True)) == set(b.keys(True, True)) and "expert_weight" in a.keys()
        assert all(torch.equal(a.get(k), b.get(k)) for k in a.keys(True, True))
    assert float(buffers[1][0].get("expert_weight").sum()) > 0  # some episodes succeeded: labels


@pytest.mark.integration
def test_the_smoke_recipe_runs_every_step_resumes_and_exports_the_network_with_its_card(tmp_path, capsys):
    run = tmp_path / "recipe"
    assert main(["recipe", "occnet", "--size", "smoke", "--run-dir", str(run)]) == 0
    out = capsys.readouterr().out
    steps = recipe_steps("occnet-selfimit", "smoke")
    assert all(f"[{i}/{len(steps)}] {s.name}: done" in out for i, s in enumerate(steps, 1))
    card = json.loads((run / "export" / "model_cards.json").read_text())["occnet-selfimit"]
    before = json.loads((run / "recipe_before.json").read_text())
    assert card["recipe_before"] == before and [b["command"].split()[1] for b in before] == ["train", "train", "demos", "demos", "fit"]
    assert before[4]["frames"] is None and all(b["cpu_hours"] > 0 for b in before)
    assert card["recipe_frames"] == sum(b["frames"] or 0 for b in before) + card["frames"]
    assert card["init_weights"] == "weights.pt" and (run / "export" / "occnet-selfimit.pt").exists()
    # again: every step is skipped; the export is written anew
    assert main(["recipe", "occnet", "--size", "smoke", "--run-dir", str(run)]) == 0
    assert capsys.readouterr().out.count("finished before, skipped") == len(steps)
    # the full size in the same folder is refused: its first step was made by another command
    assert main(["recipe", "occnet", "--run-dir", str(run)]) == 2
    assert "was made by another command" in capsys.readouterr().err
    assert json.loads((run / "warmstart" / STEP_RECORD).read_text())["command"].endswith(f"--run-dir {Path(run) / 'warmstart'}")
