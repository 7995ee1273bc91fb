"""Review srv19: a model whose class or channel list names one twice (an edited MLmodel, a
merge of two class lists) is refused where it is built, not answered with repeated
``proba_<CLASS>`` columns and probabilities summing past 1."""

from __future__ import annotations

import numpy as np
import pytest

from features.windows import WindowConfig
from terrain.errors import ConfigError
from terrain.serving.model import StreamModel

CHANNELS = ("vel_l", "vel_r", "cur_l", "cur_r")
WINDOW = WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=20.0)


class _Pipeline:
    classes_ = np.array(["ICE", "SNOW"])

    def predict_proba(self, X):
        return np.tile([0.2, 0.8], (len(X), 1))


@pytest.mark.parametrize("classes", [("ICE", "SNOW", "SNOW"), ("ICE", "SNOW", "ICE")])
def test_a_class_named_twice_is_refused(classes):
    """The service looked each class up in the pipeline's ``classes_``: SNOW twice read
    0.8 twice (probabilities summing to 1.8), and the decisions table had two
    ``proba_SNOW`` columns."""
    with pytest.raises(ConfigError, match="classes.*more than once|twice"):
        StreamModel(_Pipeline(), CHANNELS, WINDOW, classes)


def test_a_class_written_alike_is_refused():
    # 1 and "1" are one column name proba_1 of the decisions table
    with pytest.raises(ConfigError, match="twice|more than once"):
        StreamModel(_Pipeline(), CHANNELS, WINDOW, ("ICE", "SNOW", 1, "1"))


def test_a_channel_named_twice_is_refused():
    with pytest.raises(ConfigError, match="channels.*(twice|more than once)"):
        StreamModel(_Pipeline(), CHANNELS + ("vel_l",), WINDOW, ("ICE", "SNOW"))


def test_distinct_names_make_a_model():
    model = StreamModel(_Pipeline(), CHANNELS, WINDOW, ("ICE", "SNOW"))
    assert model.classes == ("ICE", "SNOW")


@pytest.mark.parametrize("key, names", [("classes", ["ICE", "SNOW", "ICE"]),
                                        ("classes", ["ICE", 1, "1"]),
                                        ("channels", ["acc_x", "vel_l", "acc_x"])])
def test_a_model_directory_naming_a_class_or_channel_twice_is_refused_naming_the_file(
        tmp_path, key, names):
    """``terrain predict`` reads the metadata (:func:`read_model_metadata`) without building
    a StreamModel: classes [ICE, SNOW, ICE] gave two ``proba_ICE`` columns."""
    from test_model_metadata_review import META, _model_dir   # same folder

    from terrain.serving.model import read_model_metadata

    path = _model_dir(tmp_path, {**META, key: names})
    with pytest.raises(ConfigError, match="more than once") as exc:
        read_model_metadata(path)
    assert str(path / "MLmodel") in str(exc.value) and key in str(exc.value)
