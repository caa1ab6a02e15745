"""superhelix.study and superhelix.stress against the command line: the same library
functions, so the same numbers. Timings (costs, seconds, the Pareto flags that follow from
the costs) differ from run to run and are not compared."""

import json
import re

import pytest

import superhelix


def rust_e(value, digits):
    """`value` as Rust's `{:.<digits>e}` prints it: `-4.647e-3`, `0.00e0`."""
    mantissa, exponent = f"{value:.{digits}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def test_study_gives_the_numbers_the_command_writes(cli, tmp_path):
    out = tmp_path / "study"
    done = cli("study", "--quick", "--only", "frequency", "--out", out)
    assert done.returncode == 0, done.stderr
    written = json.loads((out / "study.json").read_text())
    s = superhelix.study(only="frequency", quick=True)
    assert s["quick"] is True
    assert [p["key"] for p in s["problems"]] == ["frequency"]
    assert s["cost_by_elements"] == written["cost_by_elements"] == []
    (mine,), (theirs,) = s["problems"], written["problems"]
    for key in ("key", "title", "static", "spatial", "convergence", "tolerance", "rotary"):
        assert mine[key] == theirs[key], key
    # the points are listed by cost, which is a timing: compare them by setting
    timed = {"cost_seconds", "pareto"}
    by_label = {p["label"]: p for p in theirs["points"]}
    assert len(mine["points"]) == len(by_label) > 10
    for p in mine["points"]:
        q = by_label[p["label"]]
        assert {k: v for k, v in p.items() if k not in timed} == {
            k: v for k, v in q.items() if k not in timed
        }, p["label"]
        assert p["cost_seconds"] > 0
    assert all("error" in p for p in mine["points"])


def test_study_writes_the_commands_files(tmp_path):
    s = superhelix.study(only="frequency", quick=True, out=str(tmp_path))
    assert (tmp_path / "report.md").exists()
    assert (tmp_path / "frequency.svg").exists()
    written = json.loads((tmp_path / "study.json").read_text())
    assert written["command"] == s["command"] == 'superhelix.study(only="frequency", quick=True)'
    assert [p["error"] for p in written["problems"][0]["points"]] == [
        p["error"] for p in s["problems"][0]["points"]
    ]


def test_study_refuses_an_unknown_problem_naming_the_argument():
    with pytest.raises(ValueError, match=r"^only: `knot` is not a problem"):
        superhelix.study(only="knot", quick=True)


FILTER = "conservative/smooth"


def test_stress_gives_the_numbers_the_command_prints(cli):
    done = cli("stress", "--quick", "--filter", FILTER, "--verbose")
    assert done.returncode == 0, done.stdout + done.stderr
    lines = {}
    for line in done.stdout.splitlines():
        m = re.match(r"^(ok  |FAIL) (\S+) (steps=.*)$", line)
        if m:
            lines[m.group(2)] = (m.group(1).strip(), dict(kv.split("=", 1) for kv in m.group(3).split()))
    r = superhelix.stress(quick=True, filter=FILTER)
    assert r["count"] == len(r["cases"]) == len(lines) >= 4
    assert r["failed"] == 0
    assert re.search(rf"cases={r['count']} failed=0\s*$", done.stdout)
    assert r["report"].endswith(f"cases={r['count']} failed=0\n")

    def optional(v):
        return "-" if v is None else rust_e(v, 3)

    for c in r["cases"]:
        status, printed = lines[c["name"]]
        assert c["passed"] == (status == "ok")
        assert c["group"] == "conservative" and c["failure"] is None
        for key in ("steps", "substeps", "solves", "limited", "unbalanced", "newton_fallbacks"):
            assert printed[key] == str(c[key]), (c["name"], key)
        mean = c["mean_kinetic"]
        mine = {
            "T/B": f"{c['kinetic_peak']:.3f}",
            "meanT/B": "-" if mean is None else f"{mean[0]:.3f}/{mean[1]:.3f}",
            "dE/S": optional(c["energy_growth"]),
            "rise/S": optional(c["energy_rise"]),
            "stretch": rust_e(c["stretch"], 2),
            "frame": rust_e(c["frame_error"], 2),
            "penetration": rust_e(c["penetration"], 2),
        }
        for key, value in mine.items():
            assert printed[key] == value, (c["name"], key, printed[key], value)
        assert c["seconds"] >= 0


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"integrator": "leapfrog"}, "integrator"),
        ({"field_stiffness": "soft"}, "field_stiffness"),
        ({"engine": "gpu"}, "engine"),
        ({"max_split_depth": 99}, "max_split_depth"),
        ({"tolerance": 2.0}, "tolerance"),
    ],
)
def test_stress_refuses_a_bad_option_naming_the_argument(kwargs, field):
    with pytest.raises(ValueError, match=rf"^{field}: "):
        superhelix.stress(quick=True, filter=FILTER, **kwargs)
