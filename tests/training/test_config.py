"""The training settings: a small core, one config per teacher, the flat names the command line,
checkpoints and model cards use, and a trainer that never asks which teacher it has."""

import ast
import dataclasses
from pathlib import Path

import pytest

from occrl.training import TRAIN_PRESETS, TrainConfig, get_train_config
from occrl.training.config import ImitationConfig, PromotionConfig, same_run_settings
from occrl.training.teachers import TEACHERS, HybridActingTeacher, ObservedClearingTeacher, Teacher

TRAINING = Path(__file__).resolve().parents[2] / "occrl" / "training"


def test_the_core_config_has_at_most_30_documented_fields():
    fields = dataclasses.fields(TrainConfig)
    assert len(fields) <= 30
    docs = TrainConfig.field_docs()  # every flat setting (every occrl train option) has its docstring
    assert set(docs) == set(TrainConfig.setting_types()) and all(docs.values())
    for cls in (PromotionConfig, ImitationConfig, *TEACHERS.values()):
        assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen


def teacher_name_comparisons(source: str) -> list[str]:
    """Comparisons of something named like a teacher with a teacher's name or names (``teacher ==
    "hybrid"``, ``c.imitation_teacher in ("self", ...)``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        named = any("teacher" in ast.unparse(op) for op in operands if not isinstance(op, ast.Constant))
        constants = [e for op in operands for e in (op.elts if isinstance(op, (ast.Tuple, ast.List, ast.Set)) else [op])]
        strings = any(isinstance(e, ast.Constant) and e.value in TEACHERS for e in constants)
        if named and strings:
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_no_code_in_the_training_package_compares_a_teacher_name():
    assert teacher_name_comparisons('if c.imitation_teacher in ("hybrid", "self"):\n    pass') != []  # the check tells one
    assert teacher_name_comparisons('if config.teacher.name == "hybrid":\n    pass') != []
    found = {path.name: teacher_name_comparisons(path.read_text()) for path in sorted(TRAINING.glob("*.py"))}
    assert {name: hits for name, hits in found.items() if hits} == {}


def test_every_teacher_is_registered_under_its_name_with_its_own_settings():
    assert list(TEACHERS) == ["scripted", "clearing", "clearing-observed", "hybrid", "hybrid-acting", "hierarchical", "self"]
    for name, cls in TEACHERS.items():
        assert issubclass(cls, Teacher) and cls.name == name
        assert cls().settings() == {f.name: f.default for f in dataclasses.fields(cls)}


def test_the_flat_settings_read_back_into_the_nested_form():
    for preset in TRAIN_PRESETS.values():
        assert TrainConfig.from_dict(preset.to_dict()) == preset == TrainConfig.from_dict(preset.flat_settings())
    cfg = get_train_config(
        "cpu-curriculum",
        imitation_teacher="hybrid-acting",
        collector="single",
        teacher_inference="onnxruntime",
        retrieval_takeover=0.5,
        promotion_eval_tasks=100,
        replay_stage_workers=0,
    )
    assert cfg.imitation.teacher == HybridActingTeacher(inference="onnxruntime", retrieval_takeover=0.5)
    assert cfg.imitation.iterations == 100_000 and cfg.promotion == PromotionConfig(rule="hybrid", eval_every=25, eval_tasks=100)
    flat = cfg.flat_settings()
    assert flat["teacher_inference"] == "onnxruntime" and flat["teacher_search"] == "learner"  # another teacher's: its default
    assert set(flat) == set(TrainConfig.setting_types())
    assert get_train_config("paper").imitation is None and get_train_config("tiny").imitation == ImitationConfig(updates=3)
    assert get_train_config("tiny", imitation_iters=4).imitation == ImitationConfig(iterations=4, updates=3)
    whole = ImitationConfig(iterations=2, teacher=ObservedClearingTeacher(search="hierarchical"))
    assert get_train_config("tiny", imitation=whole, lr=1e-3).imitation == whole


def test_a_teacher_setting_for_another_teacher_is_refused_and_its_default_ignored():
    with pytest.raises(
        ValueError, match=r"teacher_action_noise applies to imitation_teacher 'clearing-observed' / 'hierarchical', not 'hybrid'"
    ):
        get_train_config("tiny", imitation_iters=2, imitation_teacher="hybrid", teacher_action_noise=0.1)
    assert get_train_config("tiny", imitation_teacher="hybrid", teacher_action_noise=0.0).imitation.teacher == TEACHERS["hybrid"]()
    with pytest.raises(ValueError, match="imitation_teacher must be one of"):
        get_train_config("tiny", imitation_teacher="oracle")
    with pytest.raises(ValueError, match="unknown training settings"):
        TrainConfig.from_dict({**get_train_config("tiny").to_dict(), "speed": 2})


def test_a_resumed_run_compares_settings_in_either_form():
    cfg = get_train_config("tiny", imitation_iters=3, imitation_teacher="hybrid")
    assert same_run_settings(cfg.flat_settings(), cfg.to_dict())  # a checkpoint from before the nested form
    onnx = get_train_config("tiny", imitation_iters=3, imitation_teacher="hybrid", teacher_inference="onnxruntime")
    assert same_run_settings(cfg.to_dict(), onnx.to_dict())  # inference changes rounding only
    assert not same_run_settings(cfg.to_dict(), get_train_config("tiny", imitation_iters=4, imitation_teacher="hybrid").to_dict())


def test_unknown_nested_settings_are_refused_naming_the_allowed_ones():
    nested = get_train_config("tiny", imitation_iters=5, imitation_teacher="clearing-observed").to_dict()
    for where, bad in (("imitation", {"bogus": 1}), ("promotion", {"bogus": 1})):
        broken = {**nested, where: {**nested[where], **bad}}
        with pytest.raises(ValueError, match=r"unknown .*settings \['bogus'\]; allowed: "):
            TrainConfig.from_dict(broken)
    broken = {**nested, "imitation": {**nested["imitation"], "teacher": {**nested["imitation"]["teacher"], "bogus": 1}}}
    with pytest.raises(ValueError, match=r"unknown clearing-observed teacher settings \['bogus'\]"):
        TrainConfig.from_dict(broken)
