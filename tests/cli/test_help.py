"""What ``occrl --help`` and each command's help show a user, and how fast the top level answers."""

import argparse
import re
import subprocess
import sys
from pathlib import Path

import pytest

from occrl.cli import main, make_parser
from occrl.training import TrainConfig

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ["demo", "train", "eval", "export", "bench", "tags", "calibrate", "demos", "fit", "recipe"]


def command_parsers() -> dict[str, argparse.ArgumentParser]:
    parser = make_parser()
    [sub] = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {"occrl": parser, **sub.choices}


def test_top_level_help_imports_no_torch_and_builds_no_training_options():
    code = (
        "import sys\n"
        "from occrl.cli import main\n"
        "assert main(['--help']) == 0\n"
        "print('heavy:', sorted(m for m in sys.modules if m in ('torch', 'tensordict', 'torchrl') or m.startswith('occrl.training')))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 0, run.stderr
    assert "usage: occrl" in run.stdout and "examples:" in run.stdout
    assert run.stdout.strip().endswith("heavy: []")


def test_every_option_of_every_command_has_help_without_markup_and_shows_its_default():
    parsers = command_parsers()
    assert set(parsers) == {"occrl", *COMMANDS}
    for name, parser in parsers.items():
        text = parser.format_help()  # the train parser adds its training options here
        assert "`" not in text and not re.search(r":(class|func|meth|mod|attr):", text), name
        assert "examples:" in (parser.epilog or ""), f"{name} has no examples"
        formatter = parser._get_formatter()
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)):
                continue
            shown = formatter._expand_help(action)
            flag = action.option_strings[-1] if action.option_strings else action.dest
            assert len(shown) > 10, f"{name} {flag} has no help"
            if action.option_strings and not action.required:
                assert "(default" in shown or "(required" in shown, f"{name} {flag} does not show its default: {shown!r}"
    assert len(parsers["train"]._actions) > len(TrainConfig.setting_types())  # every training setting is an option


def test_train_help_puts_the_common_options_first_and_shows_the_presets_values(capsys):
    assert main(["train", "--help"]) == 0
    paper = capsys.readouterr().out
    assert paper.index("common options:") < paper.index("starting and saving:") < paper.index("training settings of preset paper")
    common = paper[paper.index("common options:") : paper.index("starting and saving:")]
    assert all(flag in common for flag in ("--preset", "--run-dir", "--show-config", "--device", "--num-envs", "--lr"))
    assert re.search(r"--num-envs NUM_ENVS\s+Worlds collected in parallel \(over all collector\s+workers\)\. \(default: 30\)", paper)
    assert main(["train", "--preset", "tiny", "--help"]) == 0
    tiny = capsys.readouterr().out
    assert "training settings of preset tiny" in tiny and re.search(r"workers\)\. \(default: 4\)", tiny)  # tiny's num_envs
    assert re.search(r"--optimizer \{rmsprop,adam\}\s+\"rmsprop\" \(the paper\) or \"adam\"\. \(default: rmsprop\)", tiny)
    assert main(["train", "--preset=cpu", "--help"]) == 0
    assert re.search(r"\(default: adam\)", capsys.readouterr().out)


def test_show_config_prints_the_resolved_settings_and_trains_nothing(tmp_path, capsys):
    assert main(["train", "--preset", "tiny", "--lr", "0.002", "--no-heatmap", "--show-config"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("training settings of preset tiny with --no-heatmap --lr 0.002 (32 frames per iteration):")
    assert re.search(r"\n  lr +0\.002   \(option; preset tiny: 5e-05\)\n", out)
    assert re.search(r"\n  heatmap +False   \(option; preset tiny: True\)\n", out)
    assert re.search(r"\n  num_envs +4\n", out) and len(out.splitlines()) == 1 + len(TrainConfig.setting_types())  # one line each
    assert main(["train", "--preset", "tiny", "--num-envs", "3", "--workers", "2", "--collector", "multi", "--show-config"]) == 2
    assert "num_envs" in capsys.readouterr().err  # an invalid combination is refused, as the run would
    assert main(["train", "--preset", "tiny"]) == 2  # neither a run folder nor --show-config
    assert "give --run-dir" in capsys.readouterr().err


def test_the_command_line_names_no_issue_numbers():
    for path in sorted((ROOT / "occrl" / "cli").glob("*.py")):
        assert not re.search(r"issue\s*#?\s*\d+", path.read_text(), re.IGNORECASE), path


@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_help_is_printed_without_error(command, capsys):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: occrl {command}") and "examples:" in out
