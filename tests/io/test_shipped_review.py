"""verify_manifest on a manifest of another structure: typed errors naming the key."""

import json
import re

import pytest

from terrain.errors import DataFormatError
from terrain.io.shipped import verify_manifest


@pytest.mark.parametrize("manifest, key", [
    ({}, "'datasets' is missing"),
    ({"datasets": []}, "'datasets' must be an object"),
    ({"datasets": {"vulpi": {"terrains": ["CONCRETE"]}}}, "'datasets.vulpi.files' is missing"),
    ({"datasets": {"vulpi": {"terrains": ["CONCRETE"], "files": ["vulpi/imu.parquet"]}}},
     "'datasets.vulpi.files' must be a non-empty object"),
])
def test_verify_manifest_names_the_key_of_a_malformed_manifest(tmp_path, manifest, key):
    # it raised a bare KeyError or AttributeError
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DataFormatError, match=re.escape(key)) as err:
        verify_manifest(tmp_path)
    assert err.value.path == str(tmp_path / "manifest.json")
