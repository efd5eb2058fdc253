"""The package takes what the command line takes: a model file's path as a
string, effect names as one comma-separated string, a band as "lo:hi"."""

import pytest

import hystid

from conftest import SMALL


def test_a_toml_path_given_as_a_string_is_read_as_that_file(tmp_path, monkeypatch):
    (tmp_path / "small.toml").write_text(SMALL.read_text())
    monkeypatch.chdir(tmp_path)
    by_string = hystid.model("small.toml")
    by_text = hystid.model(SMALL.read_text())
    assert by_string.to_json() == by_text.to_json()
    with pytest.raises(FileNotFoundError):
        hystid.model("missing.toml")


def test_effect_names_and_bands_in_the_command_lines_form():
    assert hystid._names("all") == ["all"]
    assert hystid._names("default, clearance") == ["default", "clearance"]
    assert hystid._names(["cubic_stiffness"]) == ["cubic_stiffness"]
    assert hystid._band("120:200") == [120.0, 200.0]
    assert hystid._band((120, 200)) == [120.0, 200.0]
    with pytest.raises(hystid.HystidError, match="band_hz: expected LO:HI in Hz"):
        hystid._band("120-200")
    # refused by the library's rule, as `--band 200:120` is
    for reversed_band in ("200:120", (200.0, 120.0)):
        with pytest.raises(hystid.HystidError, match="band_hz: need 0 <= LO < HI"):
            hystid._band(reversed_band)


def test_a_band_as_a_string_fits_as_the_tuple(cli):
    frf = cli["frf"]
    as_text = hystid.identify(frf, element="jenkins", band_hz="120:300")
    as_tuple = hystid.identify(frf, element="jenkins", band_hz=(120.0, 300.0))
    for fit in (as_text, as_tuple):
        fit.pop("effort", None)
        fit.pop("trace", None)
    assert as_text["parameters"] == as_tuple["parameters"]
    assert as_text["error"] == as_tuple["error"]


def test_all_candidates_as_one_string_is_every_candidate(cli):
    with pytest.raises(hystid.HystidError) as e:
        hystid.diagnose(cli["frf"], candidates="all,frictionless")
    # the string was split into names: the unknown one is named whole
    assert "frictionless" in str(e.value)
    assert "unknown effect `a`" not in str(e.value)


def test_frfs_as_complex_arrays_are_the_json(cli):
    frf = cli["frf"]
    a = hystid.frf_arrays(frf)
    levels = frf["levels"]
    n = max(len(l["points"]) for l in levels)
    assert a["h"].shape == (len(levels), n, frf["max_harmonic"] + 1)
    assert a["h"].dtype == complex
    for i, level in enumerate(levels):
        assert a["level"][i] == level["level"]
        for j, p in enumerate(level["points"]):
            assert a["frequency_hz"][i, j] == p["frequency_hz"]
            for k, (re, im) in enumerate(p["h"]):
                assert a["h"][i, j, k] == complex(re, im)
            assert list(a["std_error"][i, j]) == p["std_error"]


def test_parameters_as_a_table(cli):
    fit = cli["fit"]
    t = hystid.parameters_table(fit)
    names = list(fit["parameters"])
    values = [fit["parameters"][n]["value"] for n in names]
    try:
        import pandas  # noqa: F401

        assert list(t.index) == names
        assert list(t["value"]) == values
    except ImportError:
        assert t["parameter"] == names
        assert list(t["value"]) == values
    # a diagnosis's final parameters are plain numbers
    d = hystid.parameters_table(cli["diagnosis"])
    column = d["value"]
    assert len(column) == len(cli["diagnosis"]["final"]["parameters"])
