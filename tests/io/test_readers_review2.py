"""Second review pass of the data readers (terrain.io): behaviours found unpinned by hand
mutants, and defects found on the way."""

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.io.measured import list_run_files, read_folder_run
from terrain.run import TIME


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


PRO = ["time", "velL", "velR", "curL", "curR"]


@pytest.mark.parametrize("columns", [
    PRO,                                           # the pro layout: a bare KeyError 'vel_r'
    ["time", "vel_l", "vel_r", "cur_l", "cur_r"],  # canonical names: taken without a word
    ["time", "note", "velR", "curL", "curR"],      # another layout: a bare KeyError
])
def test_a_stream_file_named_wheels_beside_the_pro_file_is_refused(
        tmp_path, write_run, synth_imu, synth_pro, columns):
    # pro_XX.csv is read as stream 'wheels' and wheels_XX.csv as an extra stream of the same
    # name, read after it (kinds in name order): it replaced the run's wheel stream without
    # a word, or raised a bare KeyError in the plausibility rules
    root = tmp_path / "runs"
    write_run(root, "ASPHALT", "00", synth_imu(duration_s=3.0), synth_pro(duration_s=3.0))
    other = synth_pro(duration_s=3.0, seed=7).rename(columns=dict(zip(PRO, columns)))
    other.to_csv(root / "ASPHALT" / "wheels_00.csv", index=False)
    for read in (lambda: read_folder_run(root / "ASPHALT"), lambda: list_run_files(root)):
        with pytest.raises(DataFormatError, match=r"read from pro_00\.csv") as err:
            _quiet(read)
        assert err.value.path == str(root / "ASPHALT" / "wheels_00.csv")
