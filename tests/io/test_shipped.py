"""Shipped Parquet format: loss-free round trip, manifest, checksums, named datasets."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pytest

from terrain.errors import ConfigError, DataFormatError
from terrain.io.measured import read_runs_dir
from terrain.io.shipped import (DATASET_INFO, DATASET_SPECS, convert_dataset, default_data_dir,
                                load_dataset, read_manifest, read_shipped, runs_equal, sha256,
                                verify_manifest)

BOREALTC_PRO = ["time", "curL", "curR", "velL", "velR"]


@pytest.fixture
def csv_tree(tmp_path, borealtc_runs, to_file_frame, write_run):
    """A small borealtc CSV tree: real rows of three runs, one without IMU, one repaired NaN."""
    root = tmp_path / "csv" / "borealtc"
    by_id = {r.run_id: r for r in borealtc_runs}
    for rid in ("borealtc/ASPHALT/00", "borealtc/SNOW/01", "borealtc/FLOORING/04"):
        run = by_id[rid]
        _, terrain, index = rid.split("/")
        wheels = to_file_frame(run.streams["wheels"].iloc[:40], BOREALTC_PRO)
        imu = None
        if run.has_imu:
            imu = to_file_frame(run.streams["imu"].iloc[:300], ["time", "wx", "wy", "wz",
                                                                "ax", "ay", "az"])
        if rid.endswith("SNOW/01"):
            imu = imu.astype(object)
            imu.loc[100, "wz"] = "nan"  # repaired on reading, counted in the manifest
        if rid.endswith("ASPHALT/00"):
            imu = imu.drop(index=range(100, 150))  # a 0.5 s gap, reported, never filled
        write_run(root, terrain, index, imu, wheels)
    return root


def test_convert_then_read_shipped_equals_reading_csv(tmp_path, csv_tree):
    out = tmp_path / "data"
    convert_dataset(csv_tree, "borealtc", out)
    shipped = read_shipped("borealtc", out)
    from_csv = read_runs_dir(csv_tree, "borealtc")
    assert [r.run_id for r in shipped] == [r.run_id for r in from_csv] == [
        "borealtc/ASPHALT/00", "borealtc/FLOORING/04", "borealtc/SNOW/01"]
    for a, b in zip(shipped, from_csv):
        assert runs_equal(a, b), a.run_id
        assert a.meta["repaired"] == b.meta["repaired"]
        assert a.meta["gaps"] == b.meta["gaps"]
    assert shipped[2].meta["repaired"] == {"imu.wz": 1}
    assert not shipped[1].has_imu
    ((start, end),) = shipped[0].meta["gaps"]["imu"]
    assert end - start == pytest.approx(0.51, abs=0.005)


def test_runs_equal_detects_a_changed_value_label_or_stream(borealtc_runs):
    run = borealtc_runs[0]
    assert runs_equal(run, run)
    imu = run.streams["imu"].copy()
    imu.iloc[10, 3] = np.nextafter(imu.iloc[10, 3], np.inf)  # one ulp
    assert not runs_equal(run, dataclasses.replace(run, streams={**run.streams, "imu": imu}))
    assert not runs_equal(run, dataclasses.replace(run, terrain="SNOW"))
    assert not runs_equal(run, dataclasses.replace(run, streams={"wheels":
                                                                 run.streams["wheels"]}))
    # the id, and a column's name with its values unchanged (a swapped label)
    assert not runs_equal(run, dataclasses.replace(run, run_id=run.run_id + "0"))
    wheels = run.streams["wheels"].rename(columns={"vel_l": "vel_r", "vel_r": "vel_l"})
    assert not runs_equal(run, dataclasses.replace(run, streams={**run.streams,
                                                                 "wheels": wheels}))


def test_manifest_records_provenance_rates_checksums(tmp_path, csv_tree):
    out = tmp_path / "data"
    entry = convert_dataset(csv_tree, "borealtc", out)
    manifest = read_manifest(out)
    assert manifest["datasets"]["borealtc"] == json.loads(json.dumps(entry))
    for key in ("source", "license", "citation"):
        assert entry[key] == DATASET_INFO["borealtc"][key] and entry[key]
    assert entry["sampling_rates_hz"] == {"imu": pytest.approx(100.0),
                                          "wheels": pytest.approx(6.5, abs=0.01)}
    assert entry["runs_without_imu"] == ["borealtc/FLOORING/04"]
    assert entry["terrains"] == ["ASPHALT", "FLOORING", "SNOW"]
    assert entry["files"] == {f"borealtc/{f}": sha256(out / "borealtc" / f)
                              for f in ("imu.parquet", "wheels.parquet")}
    for run in entry["runs"]:
        _, terrain, index = run["run_id"].split("/")
        for name, digest in run["source_files"].items():
            assert name.endswith(f"_{index}.csv")
            assert digest == sha256(csv_tree / terrain / name)
    assert verify_manifest(out) == []


def test_convert_twice_merges_datasets_in_manifest(tmp_path, csv_tree, vulpi_runs,
                                                   to_file_frame, write_run):
    out = tmp_path / "data"
    convert_dataset(csv_tree, "borealtc", out)
    vroot = tmp_path / "csv" / "vulpi"
    run = vulpi_runs[0]
    _, terrain, index = run.run_id.split("/")
    write_run(vroot, terrain, index,
              to_file_frame(run.streams["imu"].iloc[:200], ["time", "wx", "wy", "wz", "ax",
                                                            "ay", "az"]),
              to_file_frame(run.streams["wheels"].iloc[:60],
                            ["time", "velL", "velR", "curL", "curR"]))
    convert_dataset(vroot, "vulpi", out)
    assert set(read_manifest(out)["datasets"]) == {"borealtc", "vulpi"}
    (v,) = read_shipped("vulpi", out)
    assert runs_equal(v, read_runs_dir(vroot, "vulpi")[0])


def test_convert_unknown_dataset_is_rejected(tmp_path, csv_tree):
    with pytest.raises(ConfigError, match="borealtc"):
        convert_dataset(csv_tree, "husky_2030", tmp_path / "data")


def test_shipped_data_checksums_match(data_dir):
    assert verify_manifest(data_dir) == []


def test_verify_manifest_detects_corrupted_and_missing_files(tmp_path, data_dir):
    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    assert verify_manifest(copy) == []
    target = copy / "vulpi" / "wheels.parquet"
    raw = bytearray(target.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    target.write_bytes(bytes(raw))
    assert verify_manifest(copy) == ["vulpi/wheels.parquet"]
    (copy / "borealtc" / "imu.parquet").unlink()
    assert sorted(verify_manifest(copy)) == ["borealtc/imu.parquet", "vulpi/wheels.parquet"]


def test_data_dir_env_override(monkeypatch, tmp_path):
    monkeypatch.setenv("TERRAIN_DATA_DIR", str(tmp_path))
    assert default_data_dir() == tmp_path
    monkeypatch.delenv("TERRAIN_DATA_DIR")
    assert (default_data_dir() / "manifest.json").exists()


@pytest.mark.slow
def test_combined_dataset_has_nine_classes_and_seventy_runs(data_dir):
    runs = load_dataset("combined", data_dir)
    assert len(runs) == 70
    assert len({r.run_id for r in runs}) == 70
    assert len({r.terrain for r in runs}) == 9
    assert {r.dataset for r in runs} == {"borealtc", "vulpi"}
    for run in runs:
        assert run.run_id.startswith(f"{run.dataset}/{run.terrain}/")
        assert "wheels" in run.streams and len(run.streams["wheels"]) > 10


def test_borealtc_classes_and_runs_without_imu(borealtc_runs, data_dir):
    assert sorted({r.terrain for r in borealtc_runs}) == ["ASPHALT", "FLOORING", "ICE",
                                                          "SANDY_LOAM", "SNOW"]
    no_imu = sorted(r.run_id for r in borealtc_runs if not r.has_imu)
    assert no_imu == ["borealtc/FLOORING/04", "borealtc/FLOORING/06", "borealtc/ICE/01"]
    assert read_manifest(data_dir)["datasets"]["borealtc"]["runs_without_imu"] == no_imu
    with_imu = [r for r in borealtc_runs if r.has_imu]
    assert np.median([r.rate_hz("imu") for r in with_imu]) == pytest.approx(100.0, rel=0.01)


def test_vulpi_classes(vulpi_runs):
    assert sorted({r.terrain for r in vulpi_runs}) == ["CONCRETE", "DIRT_ROAD", "PLOUGHED",
                                                       "UNPLOUGHED"]
    assert all(r.has_imu for r in vulpi_runs)
    assert [r.run_id for r in vulpi_runs if r.terrain == "DIRT_ROAD"] == ["vulpi/DIRT_ROAD/1"]


def test_unknown_dataset_lists_valid_names(data_dir):
    with pytest.raises(ConfigError) as info:
        load_dataset("husky_2030", data_dir)
    for name in DATASET_SPECS:
        assert name in str(info.value)
    with pytest.raises(ConfigError, match="vulpi"):
        read_shipped("combined", data_dir)


def test_dataset_without_any_imu_file_converts_and_reads_wheel_only(tmp_path, borealtc_runs,
                                                                    to_file_frame, write_run):
    root = tmp_path / "csv"
    by_id = {r.run_id: r for r in borealtc_runs}
    for rid in ("borealtc/FLOORING/04", "borealtc/ICE/01"):
        _, terrain, index = rid.split("/")
        write_run(root, terrain, index, None,
                  to_file_frame(by_id[rid].streams["wheels"].iloc[:30], BOREALTC_PRO))
    entry = convert_dataset(root, "borealtc", tmp_path / "data")
    assert list(entry["files"]) == ["borealtc/wheels.parquet"]
    assert entry["runs_without_imu"] == ["borealtc/FLOORING/04", "borealtc/ICE/01"]
    runs = read_shipped("borealtc", tmp_path / "data")
    assert [set(r.streams) for r in runs] == [{"wheels"}, {"wheels"}]


@pytest.fixture
def vulpi_copy(tmp_path, data_dir):
    """A copy of the shipped data/ whose Vulpi part the tests below edit."""
    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    return copy


def _edit_manifest(data_dir, fn):
    path = data_dir / "manifest.json"
    manifest = json.loads(path.read_text())
    fn(manifest["datasets"]["vulpi"])
    path.write_text(json.dumps(manifest))
    return path


@pytest.mark.slow
def test_a_parquet_file_edited_after_conversion_is_refused_by_its_checksum(vulpi_copy):
    # a valid Parquet file with a column dropped (or a duplicated timestamp, a NaN burst):
    # none of the CSV reader's rules ran on it, so the reader refuses it by its checksum
    import pandas as pd
    path = vulpi_copy / "vulpi" / "wheels.parquet"
    pd.read_parquet(path).drop(columns="cur_l").to_parquet(path)
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", vulpi_copy)
    text = str(info.value)
    assert info.value.path == str(path) and "SHA-256" in text and "terrain convert" in text
    assert "datasets.vulpi.files.vulpi/wheels.parquet" in text
    assert read_shipped("borealtc", vulpi_copy)  # the other dataset is untouched


def _bad_wz_strings(t):
    t["wz"] = t["wz"].astype(str)
    return t


def _nan_burst(t):
    t.loc[t.index[100:121], "wx"] = np.nan
    return t


def _swapped_rows(t):
    t.loc[t.index[[50, 51]], "t_s"] = t.loc[t.index[[51, 50]], "t_s"].to_numpy()
    return t


@pytest.mark.parametrize("edit, error, column, words", [
    (lambda t: t.drop(columns="wz"), "MissingColumnError", "wz", "lacks column 'wz'"),
    (_bad_wz_strings, "NonNumericError", "wz", "not numbers"),
    (_nan_burst, "NonFiniteError", "wx", "21 non-finite value(s)"),
    (_swapped_rows, "TimestampError", "t_s", "increase strictly"),
])
def test_a_parquet_file_and_its_checksum_both_edited_are_refused_by_the_readers_rules(
        vulpi_copy, edit, error, column, words):
    # editing the manifest's SHA-256 with the file skipped every rule: a dropped column
    # or text in it reached cv and the audit as a KeyError / TypeError, a NaN burst or
    # swapped rows were accepted silently
    import pandas as pd
    from terrain.io.shipped import sha256 as digest
    path = vulpi_copy / "vulpi" / "imu.parquet"
    edit(pd.read_parquet(path)).to_parquet(path)
    _edit_manifest(vulpi_copy, lambda e: e["files"].__setitem__("vulpi/imu.parquet",
                                                                digest(path)))
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", vulpi_copy)
    assert type(info.value).__name__ == error
    assert info.value.path == str(path) and info.value.column == column
    assert words in str(info.value) and "\n" not in str(info.value)
    if error in ("NonFiniteError", "TimestampError"):
        assert "run vulpi/CONCRETE/1" in str(info.value) and info.value.row is not None


@pytest.mark.parametrize("column, value, error", [("wx", np.nan, "NonFiniteError"),
                                                  ("t_s", -1.0, "TimestampError")])
def test_a_bad_value_of_a_later_run_names_its_row_of_the_file(vulpi_copy, column, value,
                                                              error):
    # the row named was the run's own (data row 10 of a run whose row 10 is row 3506 of the
    # file), and a NaN was shown as "np.float64(nan)"
    import pandas as pd
    from terrain.io.shipped import sha256 as digest
    path = vulpi_copy / "vulpi" / "imu.parquet"
    table = pd.read_parquet(path)
    rid = list(dict.fromkeys(table["run_id"].astype(str)))[3]
    at = int(np.flatnonzero((table["run_id"].astype(str) == rid).to_numpy())[10])
    table.loc[table.index[at], column] = value
    table.to_parquet(path)
    _edit_manifest(vulpi_copy, lambda e: e["files"].__setitem__("vulpi/imu.parquet",
                                                                digest(path)))
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", vulpi_copy)
    assert type(info.value).__name__ == error and info.value.column == column
    assert info.value.row == at and f"run {rid}: " in str(info.value)
    assert "row 10 of the run" in str(info.value)
    assert "np.float64" not in str(info.value)


@pytest.mark.parametrize("edit, key", [
    (lambda e: e.pop("runs"), "datasets.vulpi.runs' is missing"),
    (lambda e: e.__setitem__("runs", "x"), "datasets.vulpi.runs' must be a non-empty list"),
    (lambda e: e.pop("files"), "datasets.vulpi.files' is missing"),
    (lambda e: e["runs"][2].pop("terrain"), "datasets.vulpi.runs[2].terrain' is missing"),
    (lambda e: e["runs"][2].__setitem__("terrain", "MARS"),
     "datasets.vulpi.runs[2].terrain' must be one of"),
    (lambda e: e["runs"][2].__setitem__("terrain", None),
     "datasets.vulpi.runs[2].terrain' must be one of"),
    (lambda e: e["runs"][1].__setitem__("gaps", None), "datasets.vulpi.runs[1].gaps' must be"),
    (lambda e: e["runs"][1].__setitem__("gaps", {"wheels": [[1]]}),
     "datasets.vulpi.runs[1].gaps' must be"),
    (lambda e: e["runs"].append(dict(e["runs"][0])), "is listed twice"),
    (lambda e: e["files"].__setitem__("vulpi/imu.parquet", "0" * 63),
     "datasets.vulpi.files.vulpi/imu.parquet' must be a SHA-256"),
    (lambda e: e["runs"][1].__setitem__("has_imu", "yes"),
     "datasets.vulpi.runs[1].has_imu' must be a boolean"),
    (lambda e: e.__setitem__("runs_without_imu", "none"),
     "datasets.vulpi.runs_without_imu' must be a list of run ids"),
    (lambda e: e["runs"][1].__setitem__("file_warnings", "cut off"),
     "datasets.vulpi.runs[1].file_warnings' must be a list of messages"),
    # these two were not checked: a bare TypeError / ValueError of dict(), or a count of
    # "many" blank lines kept for the input report to add up
    (lambda e: e["runs"][1].__setitem__("skipped_lines", 3),
     "datasets.vulpi.runs[1].skipped_lines' must be an object of counts"),
    (lambda e: e["runs"][1].__setitem__("skipped_lines", {"imu.blank": "many"}),
     "datasets.vulpi.runs[1].skipped_lines' must be an object of counts"),
    (lambda e: e["runs"][1].__setitem__("ignored_columns", ["x"]),
     "datasets.vulpi.runs[1].ignored_columns' must be an object of lists of column names"),
    (lambda e: e["runs"][1].__setitem__("ignored_columns", {"imu": "x"}),
     "datasets.vulpi.runs[1].ignored_columns' must be an object of lists of column names"),
])
def test_a_manifest_entry_of_another_structure_names_its_key(vulpi_copy, edit, key):
    path = _edit_manifest(vulpi_copy, edit)
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", vulpi_copy)
    assert info.value.path == str(path) and key in str(info.value)
    assert "\n" not in str(info.value)


def test_runs_of_the_files_and_of_the_manifest_must_agree(vulpi_copy):
    dropped = {}
    path = _edit_manifest(vulpi_copy, lambda e: dropped.update(e["runs"].pop(3)))
    with pytest.raises(DataFormatError, match=r"1 run\(s\) not listed") as info:
        read_shipped("vulpi", vulpi_copy)
    assert dropped["run_id"] in str(info.value) and info.value.column == "run_id"
    _edit_manifest(vulpi_copy, lambda e: e["runs"].append({**dropped, "run_id": "vulpi/X/9"}))
    _edit_manifest(vulpi_copy, lambda e: e["runs"].insert(3, dropped))
    with pytest.raises(DataFormatError, match="'vulpi/X/9'.*has no rows") as info:
        read_shipped("vulpi", vulpi_copy)
    assert info.value.path == str(path)


def test_a_manifest_that_omits_a_stream_file_that_exists_is_refused(vulpi_copy):
    # a manifest whose 'files' lacked vulpi/imu.parquet made all 15 Vulpi runs wheel-only
    # without a word (the IMU file was skipped as "no run of the dataset has this stream")
    imu = vulpi_copy / "vulpi" / "imu.parquet"
    assert all("imu" in r.streams for r in read_shipped("vulpi", vulpi_copy))
    path = _edit_manifest(vulpi_copy, lambda e: e["files"].pop("vulpi/imu.parquet"))
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", vulpi_copy)
    text = str(info.value)
    assert info.value.path == str(path) and str(imu) in text and "\n" not in text
    assert "'datasets.vulpi.files' does not list vulpi/imu.parquet" in text
    assert verify_manifest(vulpi_copy) == ["vulpi/imu.parquet"]
    # the file gone as well: the runs still say they have an IMU (has_imu), refused
    imu.unlink()
    assert verify_manifest(vulpi_copy) == []
    with pytest.raises(DataFormatError, match=r"'datasets.vulpi.runs\[0\].has_imu' is true "
                                              r"but imu.parquet holds no row of run"):
        read_shipped("vulpi", vulpi_copy)


@pytest.mark.slow
def test_has_imu_and_runs_without_imu_must_agree_with_the_imu_rows(vulpi_copy, data_dir):
    import shutil
    path = _edit_manifest(vulpi_copy, lambda e: e["runs"][4].__setitem__("has_imu", False))
    with pytest.raises(DataFormatError, match=r"runs\[4\].has_imu' is false but imu.parquet "
                                              "holds rows") as info:
        read_shipped("vulpi", vulpi_copy)
    assert info.value.path == str(path)
    _edit_manifest(vulpi_copy, lambda e: e["runs"][4].__setitem__("has_imu", True))
    assert read_shipped("vulpi", vulpi_copy)
    _edit_manifest(vulpi_copy, lambda e: e["runs_without_imu"].append(e["runs"][4]["run_id"]))
    with pytest.raises(DataFormatError, match=r"'datasets.vulpi.runs_without_imu' lists "
                                              r"\['vulpi/"):
        read_shipped("vulpi", vulpi_copy)
    # BorealTC lists its three runs without an IMU: dropping one is refused too
    shutil.copy(data_dir / "manifest.json", vulpi_copy / "manifest.json")
    manifest = json.loads(path.read_text())
    manifest["datasets"]["borealtc"]["runs_without_imu"].remove("borealtc/FLOORING/04")
    path.write_text(json.dumps(manifest))
    with pytest.raises(DataFormatError, match=r"without_imu' omits \['borealtc/FLOORING/04'\], "
                                              "which have none in imu.parquet"):
        read_shipped("borealtc", vulpi_copy)


def test_invalid_manifest_json_names_its_line_and_column(tmp_path, data_dir):
    import shutil

    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    path = copy / "manifest.json"
    lines = path.read_text().splitlines()
    lines[2] += ",,"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFormatError, match=r"invalid JSON: .*, column \d+\).*terrain "
                                              r"convert") as info:
        read_manifest(copy)
    assert info.value.path == str(path) and info.value.line == 3


def test_converting_runs_under_a_dataset_of_another_imu_rate_warns(tmp_path, csv_tree):
    # BorealTC's 100 Hz IMU converted as vulpi (50 Hz) would be aligned at 50 Hz and lose
    # its 25-50 Hz band without a word
    from terrain.errors import DataWarning
    with pytest.warns(DataWarning, match=r"IMU runs at 100 Hz, dataset 'vulpi' at 50 Hz"):
        convert_dataset(csv_tree, "vulpi", tmp_path / "as_vulpi")
    import warnings
    with warnings.catch_warnings(record=True) as seen:   # its own dataset: no such warning
        warnings.simplefilter("always")
        convert_dataset(csv_tree, "borealtc", tmp_path / "as_borealtc")
    assert not [w for w in seen if "IMU runs at" in str(w.message)]


def test_convert_keeps_the_count_of_skipped_lines_and_ignored_columns(tmp_path, csv_tree):
    # a column the readers do not read and comment / blank lines vanished in conversion, and
    # terrain convert's report of the shipped runs said "nothing repaired, dropped or skipped"
    from terrain.io.report import input_report
    pro = csv_tree / "ASPHALT" / "pro_00.csv"
    lines = pro.read_text().splitlines()
    pro.write_text("\n".join([lines[0] + ",batt", "# logged by the robot", lines[1] + ",24",
                              ""] + [x + ",24" for x in lines[2:]]) + "\n")
    out = tmp_path / "data"
    convert_dataset(csv_tree, "borealtc", out)
    shipped = {r.run_id: r for r in read_shipped("borealtc", out)}
    from_csv = {r.run_id: r for r in read_runs_dir(csv_tree, "borealtc")}
    run = "borealtc/ASPHALT/00"
    for key in ("skipped_lines", "ignored_columns"):
        assert shipped[run].meta[key] == from_csv[run].meta[key] != {}
    text = input_report(list(shipped.values())).text()
    assert "ignored 1 column(s)" in text and "wheels.batt" in text
    assert "skipped 2 blank/comment line(s)" in text


def test_convert_keeps_the_warnings_of_the_csv_readers(tmp_path, csv_tree):
    # a wheel file without its last line break (rule last_line) was warned when converted,
    # then lost: the shipped run's meta["warnings"] held only the clock finding recomputed
    # on reading, and its input report counted 1 warning where the CSV run counted 2
    from terrain.errors import DataWarning
    from terrain.io.report import input_report
    pro = csv_tree / "ASPHALT" / "pro_00.csv"
    pro.write_text(pro.read_text().rstrip("\n"))
    out = tmp_path / "data"
    with pytest.warns(DataWarning, match="last_line"):
        convert_dataset(csv_tree, "borealtc", out)
    with pytest.warns(DataWarning, match="last_line"):  # warned on reading, as from CSV
        shipped = {r.run_id: r for r in read_shipped("borealtc", out)}
    with pytest.warns(DataWarning, match="last_line"):
        from_csv = {r.run_id: r for r in read_runs_dir(csv_tree, "borealtc")}
    run = "borealtc/ASPHALT/00"
    got = shipped[run].meta["warnings"]
    assert len(got) == len(from_csv[run].meta["warnings"]) == 2
    assert "rule last_line" in got[0] and str(pro) in got[0] and "clock_overlap" in got[1]
    assert all(not r.meta["warnings"] or "last_line" not in r.meta["warnings"][0]
               for rid, r in shipped.items() if rid != run)
    table = input_report(list(shipped.values())).table.set_index("run_id")
    assert table.loc[run, "warnings"] == 2


def _data_dir_state(out):
    """Name and SHA-256 of every file under a data folder (hidden temporary files included)."""
    return {str(p.relative_to(out)): sha256(p) for p in sorted(out.rglob("*")) if p.is_file()}


def test_convert_refuses_a_manifest_it_cannot_update_before_writing_anything(tmp_path,
                                                                             csv_tree):
    # the Parquet files were written first and the manifest read afterwards with a bare
    # json.loads: a trailing comma was an internal error (JSONDecodeError, exit 1), a list an
    # AttributeError, and the new files stayed beside the old checksums: dataset unreadable
    from terrain.cli import main
    out = tmp_path / "data"
    convert_dataset(csv_tree, "borealtc", out)
    manifest = out / "manifest.json"
    good = manifest.read_text()
    shutil.rmtree(csv_tree / "SNOW")               # another conversion would change files
    comma = good.rstrip()[:-1] + ",}\n"            # a hand edit left a trailing comma
    for text, match, line in (
            (comma, r"invalid JSON: .*column 2\); fix it", comma.count("\n")),
            ("[1, 2]\n", "must be a JSON object with a 'datasets' key, got a list", None),
            ('{"datasets": [1]}\n', "key 'datasets' must be an object of datasets", None)):
        manifest.write_text(text)
        before = _data_dir_state(out)
        with pytest.raises(DataFormatError, match=match) as info:
            convert_dataset(csv_tree, "borealtc", out)
        assert info.value.path == str(manifest) and info.value.line == line
        assert "nothing was converted" in str(info.value)
        assert _data_dir_state(out) == before
        assert main(["convert", str(csv_tree), "--dataset", "borealtc", "--data-dir",
                     str(out)]) == 2
        assert _data_dir_state(out) == before
    manifest.write_text(good)                      # the user fixes the comma: data intact
    assert len(read_shipped("borealtc", out)) == 3 and verify_manifest(out) == []


def test_a_conversion_that_fails_while_writing_leaves_the_data_as_it_was(tmp_path, csv_tree,
                                                                         monkeypatch):
    import pandas as pd
    out = tmp_path / "data"
    convert_dataset(csv_tree, "borealtc", out)
    before = _data_dir_state(out)
    shutil.rmtree(csv_tree / "SNOW")
    written = []
    to_parquet = pd.DataFrame.to_parquet

    def fail_on_the_second(self, path, *args, **kwargs):
        written.append(path)
        if len(written) == 2:
            raise OSError(28, "No space left on device")
        return to_parquet(self, path, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_parquet", fail_on_the_second)
    with pytest.raises(OSError, match="No space left"):
        convert_dataset(csv_tree, "borealtc", out)
    assert len(written) == 2
    assert _data_dir_state(out) == before           # no new file, no temporary file left
    monkeypatch.undo()
    assert len(read_shipped("borealtc", out)) == 3
    convert_dataset(csv_tree, "borealtc", out)      # and a conversion that succeeds
    assert [r.run_id for r in read_shipped("borealtc", out)] == [
        "borealtc/ASPHALT/00", "borealtc/FLOORING/04"]
    assert not [p for p in out.rglob(".*")]


def test_a_manifest_with_a_non_utf8_byte_names_its_offset_and_line(tmp_path):
    # it said only "unreadable manifest (UnicodeDecodeError)", with nothing to find the byte
    path = tmp_path / "manifest.json"
    path.write_bytes(b'{\n  "datasets": {\n    "vulpi": "caf\xe9"\n  }\n}\n')
    with pytest.raises(DataFormatError) as info:
        read_manifest(tmp_path)
    assert info.value.path == str(path) and info.value.line == 3
    assert "0xe9 at byte offset 35" in str(info.value) and "UTF-8" in str(info.value)


@pytest.mark.parametrize("t, row, words", [([np.nan, 0.1, 0.2], 0, "nan is not finite"),
                                           ([0.0, 0.1, np.nan, 0.3], 2, "got nan after 0.1"),
                                           ([0.0, 0.2, 0.1, np.nan], 2, "got 0.1 after 0.2"),
                                           # strictly: a repeated timestamp is refused too
                                           ([0.0, 0.1, 0.1, 0.2], 2, "got 0.1 after 0.1")])
def test_a_shipped_run_is_refused_at_its_first_bad_timestamp(tmp_path, t, row, words):
    # a NaN first timestamp was reported at row 1 ("got 0.1 after nan")
    import pandas as pd
    from terrain.errors import TimestampError
    from terrain.io.shipped import _check_run_rows

    frame = pd.DataFrame({"t_s": t, "wz": 0.0})
    with pytest.raises(TimestampError) as info:
        _check_run_rows(frame, "vulpi/X/1", tmp_path / "imu.parquet")
    assert info.value.row == row and words in str(info.value)


@pytest.mark.parametrize("edit, message", [
    (lambda r: r["samples"].__setitem__("wheels", r["samples"]["wheels"] + 1),
     r"runs\[2\].samples' says wheels \d+ but wheels.parquet holds \d+ rows"),
    (lambda r: r["samples"].pop("imu"),
     r"runs\[2\].samples' says no imu but imu.parquet holds \d+ rows"),
    (lambda r: r.__setitem__("duration_s", r["duration_s"] + 1.0),
     r"runs\[2\].duration_s' says [\d.]+ s but its rows span [\d.]+ s"),
    (lambda r: r.__setitem__("samples", {"wheels": "many"}),
     r"runs\[2\].samples' must be an object of counts"),
])
def test_the_manifest_counts_of_a_run_must_equal_its_rows(vulpi_copy, edit, message):
    """Each run's ``samples`` and ``duration_s`` (what data/README.md calls the per-run
    durations and sample counts) were never compared with the files: a manifest saying 1
    more wheel sample, no IMU sample or a second more than the rows hold was read without a
    word. They are now checked where present, naming the key."""
    path = _edit_manifest(vulpi_copy, lambda e: edit(e["runs"][2]))
    with pytest.raises(DataFormatError, match=message) as info:
        read_shipped("vulpi", vulpi_copy)
    assert info.value.path == str(path) and "\n" not in str(info.value)


def test_runs_come_sorted_by_run_id_whatever_the_manifest_order(vulpi_copy):
    # read_shipped returned the manifest's order although its docstring (and load_dataset's)
    # says sorted by run id: a manifest listing its runs in reverse gave them reversed
    _edit_manifest(vulpi_copy, lambda e: e["runs"].reverse())
    ids = [r.run_id for r in read_shipped("vulpi", vulpi_copy)]
    assert ids == sorted(ids) and len(ids) == 15 and ids[0] == "vulpi/CONCRETE/1"
    # a manifest key in a message still counts from the manifest's own order
    _edit_manifest(vulpi_copy, lambda e: e["runs"][0].update(has_imu=False))
    with pytest.raises(DataFormatError, match=r"runs\[0\]\.has_imu.* 'vulpi/UNPLOUGHED/"):
        read_shipped("vulpi", vulpi_copy)


def test_a_manifest_duration_off_by_a_millisecond_is_refused(vulpi_copy):
    # convert_dataset writes duration_s to 3 decimals and read_shipped compares it at 3:
    # a run whose last sample is gone (one 50 Hz step) or a hand-edited figure is refused
    def longer(entry):
        entry["runs"][1]["duration_s"] = round(entry["runs"][1]["duration_s"] + 0.001, 3)

    _edit_manifest(vulpi_copy, longer)
    with pytest.raises(DataFormatError, match=r"runs\[1\]\.duration_s' says"):
        read_shipped("vulpi", vulpi_copy)


def test_a_run_labelled_with_another_terrain_than_its_folder_is_refused(vulpi_copy):
    # the label of a shipped run is the manifest's 'terrain'; one edited to another class
    # of the dataset (vulpi/CONCRETE/1 as DIRT_ROAD) was read as that class without a word
    def relabel(entry):
        run = entry["runs"][0]
        assert (run["run_id"], run["terrain"]) == ("vulpi/CONCRETE/1", "CONCRETE")
        run["terrain"] = "DIRT_ROAD"

    path = _edit_manifest(vulpi_copy, relabel)
    with pytest.raises(DataFormatError, match=r"'datasets\.vulpi\.runs\[0\]\.terrain' is "
                       r"'DIRT_ROAD' but run 'vulpi/CONCRETE/1' lies in terrain folder "
                       r"'CONCRETE'") as err:
        read_shipped("vulpi", vulpi_copy)
    assert err.value.path == str(path)
