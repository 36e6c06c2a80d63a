"""occrl export: a run's weights (latest or end of warm start) with a model card from the file itself."""

import pytest
import json

import torch

from occrl.cli import main
from occrl.training import Trainer, get_train_config, load_weights


@pytest.mark.integration
def test_export_the_warm_start_weights_with_their_own_card(tmp_path):
    run = tmp_path / "run"
    trainer = Trainer(get_train_config("tiny", imitation_iters=2, imitation_beta_iters=1), run, seed=0, progress=False, tensorboard=False)
    trainer.train(iterations=3)
    trainer.close()
    dest = tmp_path / "shipped"
    assert (
        main(
            [
                "export",
                "--run-dir",
                str(run),
                "--name",
                "occnet-warmstart",
                "--preset",
                "tiny",
                "--weights",
                "weights_warmstart.pt",
                "--dest",
                str(dest),
            ]
        )
        == 0
    )
    card = json.loads((dest / "model_cards.json").read_text())["occnet-warmstart"]
    assert card["iterations"] == 2 and card["phase"] == "imitation" and card["weights_file"] == "weights_warmstart.pt"
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert card["cpu_hours"] == round(rows[1]["cpu_hours"], 2)  # the run's measured CPU time at the exported iteration
    shipped, warm = load_weights(dest / "occnet-warmstart.pt").state_dict(), load_weights(run / "weights_warmstart.pt").state_dict()
    assert all(torch.equal(shipped[k], warm[k]) for k in warm)
    assert main(["export", "--run-dir", str(run), "--name", "occnet-warmstart", "--preset", "tiny", "--dest", str(dest)]) == 0
    assert json.loads((dest / "model_cards.json").read_text())["occnet-warmstart"]["iterations"] == 3
    # a default name stands for another network: export under the network's own name
    assert main(["export", "--run-dir", str(run), "--name", "occnet", "--preset", "tiny", "--dest", str(dest)]) == 2
    assert main(["export", "--run-dir", str(run), "--name", "mystery", "--preset", "tiny", "--dest", str(dest)]) == 2


@pytest.mark.integration
def test_a_run_started_from_other_weights_names_them_in_its_card(tmp_path):
    from occrl.modules import make_occnet
    from occrl.training import save_weights

    start = tmp_path / "start.pt"
    save_weights(start, make_occnet("paper"))
    run = tmp_path / "run"
    trainer = Trainer(get_train_config("tiny"), run, seed=0, progress=False, tensorboard=False, init_weights=start)
    trainer.train(iterations=1)
    trainer.close()
    dest = tmp_path / "shipped"
    assert main(["export", "--run-dir", str(run), "--name", "occnet-ei", "--preset", "tiny", "--dest", str(dest)]) == 0
    card = json.loads((dest / "model_cards.json").read_text())["occnet-ei"]
    assert card["init_weights"] == "start.pt" and card["summary"].endswith("started from start.pt")
    # the steps that made start.pt go into the card ahead of the run, with totals over the whole recipe
    recipe = tmp_path / "recipe.json"
    steps = [
        {"what": "data", "command": "occrl train --lr 0 ...", "frames": 1000, "cpu_hours": 0.5},
        {"what": "offline fit", "command": "python scripts/offline_imitation.py ...", "frames": None, "cpu_hours": 0.25},
    ]
    recipe.write_text(json.dumps(steps))
    export = ["export", "--run-dir", str(run), "--name", "occnet-ei", "--preset", "tiny", "--dest", str(dest)]
    assert main([*export, "--recipe-before", str(recipe)]) == 0
    card = json.loads((dest / "model_cards.json").read_text())["occnet-ei"]
    assert card["recipe_before"] == steps and card["recipe_frames"] == 1000 + card["frames"]
    assert card["recipe_cpu_hours"] == round(0.75 + card["cpu_hours"], 2) and "2 earlier steps" in card["summary"]
    assert load_weights(dest / "occnet-ei.pt") is not None


def test_a_bad_recipe_file_is_refused_with_what_a_step_needs_and_nothing_is_written(tmp_path, capsys):
    dest = tmp_path / "shipped"
    recipe = tmp_path / "recipe.json"
    for content, message in (
        ("not json", "cannot read a JSON list"),
        ("[]", "non-empty JSON list"),
        ('[{"what": "x", "command": "y", "frames": 1}]', "each step needs exactly ['command', 'cpu_hours', 'frames', 'what']"),
        ('[{"what": "x", "command": "y", "frames": -1, "cpu_hours": null}]', "frames must be a number >= 0 or null, got -1"),
    ):
        recipe.write_text(content)
        export = ["export", "--run-dir", str(tmp_path / "no-run"), "--name", "occnet-ei", "--preset", "tiny", "--dest", str(dest)]
        assert main([*export, "--recipe-before", str(recipe)]) == 2
        assert message in capsys.readouterr().err
    assert not dest.exists()
