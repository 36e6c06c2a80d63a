"""The networks shipped in the package: all present, loadable, with a model card."""

import json

import pytest
import torch

from occrl.cli import main
from occrl.pretrained import PRETRAINED_FILES, available, load_pretrained, model_card, pretrained_path


@pytest.mark.parametrize("name", sorted(PRETRAINED_FILES))
def test_every_shipped_network_loads_and_has_its_card(name):
    assert name in available()
    raw = torch.load(pretrained_path(name), map_location="cpu", weights_only=True)  # no pickled code
    assert raw["meta"] == model_card(name)
    card = model_card(name)
    for fact in ("train_preset", "seed", "iterations", "frames", "cpu_hours", "wall_hours", "stage_reached", "summary"):
        assert fact in card, f"{name}: model card lacks {fact}"
    net = load_pretrained(name)
    assert (net.heatmap is None) == (name == "occnet-noheatmap")


def test_occnet_ei_is_occnet_trained_further_and_the_cli_takes_its_name(tmp_path):
    card = model_card("occnet-ei")
    assert card["init_weights"] == "occnet.pt" and card["stage_reached"] == 2
    ei, base = load_pretrained("occnet-ei").state_dict(), load_pretrained("occnet").state_dict()
    assert ei.keys() == base.keys() and not all(torch.equal(ei[k], base[k]) for k in base)
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "eval",
                "--method",
                "stochastic-gen",
                "--weights",
                "occnet-ei",
                "--objects",
                "1-1",
                "--tasks",
                "1",
                "--out",
                str(out),
                "--no-progress",
            ]
        )
        == 0
    )
    assert json.loads(out.read_text())["network"] == "occnet-ei"


def test_occnet_takeover_is_the_takeover_runs_iteration_75_and_its_card_names_the_recipe():
    from occrl.modules.weights import load_weights

    card = model_card("occnet-takeover")
    assert card["init_weights"] == "occnet.pt" and card["iterations"] == 75 and card["frames"] == 30_000
    recipe = card["settings_beyond_preset"]
    assert recipe["imitation_teacher"] == "hybrid-acting" and recipe["retrieval_takeover"] == 0.5
    shipped = load_pretrained("occnet-takeover").state_dict()
    from pathlib import Path

    run_weights = Path(__file__).resolve().parents[1] / "checkpoints" / "retrieval-takeover50-seed0" / "weights_iteration75.pt"
    run = load_weights(run_weights).state_dict()
    assert shipped.keys() == run.keys() and all(torch.equal(shipped[k], run[k]) for k in run)
