"""The networks shipped in the package: all present, loadable, with a model card."""

import json
import subprocess
from pathlib import Path

import pytest
import torch

from occrl.cli import main
from occrl.pretrained import DEFAULT_NETWORKS, PRETRAINED_FILES, available, load_pretrained, model_card, pretrained_path

# the training facts a card records; a file's own record (its "meta", written at export) keeps them
# while the card's names (summary, init_weights) follow renames (occnet -> occnet-warmstart in 0.3.0)
FACTS = ("train_preset", "seed", "iterations", "frames", "cpu_hours", "wall_hours", "stage_reached", "phase")

REPO = Path(__file__).resolve().parents[1]
# the training runs' checkpoints left the tree at this commit; git history keeps them
RUNS_COMMIT = "53b1240"


def run_weights_state(run_file: str, tmp_path: Path) -> dict:
    """The state dict of ``checkpoints/RUN_FILE`` as committed at ``RUNS_COMMIT`` (skips without that history)."""
    from occrl.modules.weights import load_weights

    blob = subprocess.run(["git", "show", f"{RUNS_COMMIT}:checkpoints/{run_file}"], cwd=REPO, capture_output=True)
    if blob.returncode != 0:
        pytest.skip(f"needs the git history of commit {RUNS_COMMIT} (a full clone): {blob.stderr.decode().strip()}")
    path = tmp_path / Path(run_file).name
    path.write_bytes(blob.stdout)
    return load_weights(path).state_dict()


@pytest.mark.parametrize("name", sorted(PRETRAINED_FILES))
def test_every_shipped_network_loads_and_has_its_card(name):
    assert name in available()
    raw = torch.load(pretrained_path(name), map_location="cpu", weights_only=True)  # no pickled code
    card = model_card(name)
    for fact in (*FACTS, "summary"):
        assert fact in card, f"{name}: model card lacks {fact}"
    assert {k: raw["meta"][k] for k in FACTS} == {k: card[k] for k in FACTS}
    assert raw["meta"].get("settings_beyond_preset") == card.get("settings_beyond_preset")
    assert card["summary"].startswith(f"{name}: ")
    net = load_pretrained(name)
    assert (net.heatmap is None) == ("noheatmap" in name)


def test_default_names_stand_for_shipped_networks():
    assert DEFAULT_NETWORKS == {"occnet": "occnet-selfimit", "occnet-noheatmap": "occnet-noheatmap-selfimit"}
    for default, net in DEFAULT_NETWORKS.items():
        assert default in available() and pretrained_path(default) == pretrained_path(net)
        assert model_card(default) == model_card(net)
    with pytest.raises(ValueError, match="unknown pretrained network 'occnet-v9'; known: .*'occnet-warmstart'"):
        pretrained_path("occnet-v9")


def test_occnet_ei_is_occnet_warmstart_trained_further_and_the_cli_takes_its_name(tmp_path):
    card = model_card("occnet-ei")
    assert card["init_weights"] == "occnet-warmstart.pt" and card["stage_reached"] == 2
    ei, base = load_pretrained("occnet-ei").state_dict(), load_pretrained("occnet-warmstart").state_dict()
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


def test_occnet_takeover_is_the_takeover_runs_iteration_75_and_its_card_names_the_recipe(tmp_path):
    card = model_card("occnet-takeover")
    assert card["init_weights"] == "occnet-warmstart.pt" and card["iterations"] == 75 and card["frames"] == 30_000
    recipe = card["settings_beyond_preset"]
    assert recipe["imitation_teacher"] == "hybrid-acting" and recipe["retrieval_takeover"] == 0.5
    shipped = load_pretrained("occnet-takeover").state_dict()
    run = run_weights_state("retrieval-takeover50-seed0/weights_iteration75.pt", tmp_path)
    assert shipped.keys() == run.keys() and all(torch.equal(shipped[k], run[k]) for k in run)


@pytest.mark.parametrize(
    ("name", "start", "run_weights"),
    [
        ("occnet-selfimit", "occnet-takeover", "selfimit-from-fit3k/weights_iteration80.pt"),
        ("occnet-noheatmap-selfimit", "occnet-noheatmap-takeover", "selfimit-noheatmap/weights_iteration80.pt"),
    ],
)
def test_the_selfimit_networks_are_their_runs_iteration_80_and_their_cards_name_the_whole_recipe(name, start, run_weights, tmp_path):
    card = model_card(name)
    assert card["iterations"] == 80 and card["frames"] == 128_000 and card["stage_reached"] == 2
    assert card["settings_beyond_preset"]["imitation_teacher"] == "self" and card["settings_beyond_preset"]["label_episodes"] == "success"
    data9, data10, fit = card["recipe_before"]  # the teacher's demonstrations (two seeds), then the offline fit from `start`
    assert "--teacher-action-noise 0.05" in data9["command"] and "--seed 10" in data10["command"]
    assert f"--init-weights {start}" in fit["command"] and fit["frames"] is None
    assert card["recipe_frames"] == data9["frames"] + data10["frames"] + card["frames"] == 120_000 + 32_000 + 128_000
    shipped = load_pretrained(name).state_dict()
    run = run_weights_state(run_weights, tmp_path)
    assert shipped.keys() == run.keys() and all(torch.equal(shipped[k], run[k]) for k in run)


def test_the_wheel_carries_the_default_networks_and_names_where_the_others_are(tmp_path, monkeypatch):
    """pyproject's package data names exactly the default networks' files (and the cards); in an
    installation with only those, another name is refused with where to find it."""
    import re
    import shutil

    import occrl.pretrained as pretrained

    pyproject = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    shipped = set(re.findall(r'"pretrained/([\w.-]+\.pt)"', pyproject))
    assert shipped == {PRETRAINED_FILES[net] for net in DEFAULT_NETWORKS.values()}
    for file in shipped | {"model_cards.json"}:
        shutil.copy(pretrained.PRETRAINED_DIR / file, tmp_path / file)
    monkeypatch.setattr(pretrained, "PRETRAINED_DIR", tmp_path)
    assert pretrained.available() == sorted(set(DEFAULT_NETWORKS) | set(DEFAULT_NETWORKS.values()))
    assert load_pretrained("occnet") is not None and model_card("occnet-ei")  # the cards travel with the wheel
    with pytest.raises(FileNotFoundError, match=r"carries the default networks .* occrl/pretrained/\*\.pt of the source repository"):
        pretrained_path("occnet-ei")
