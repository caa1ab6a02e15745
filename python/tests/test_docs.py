"""The Python blocks of docs/from-pyelastica.md run as they stand and print what their
comments say."""

import contextlib
import io
import pathlib
import re

import numpy as np

PAGE = pathlib.Path(__file__).resolve().parents[2] / "docs" / "from-pyelastica.md"


def blocks():
    return re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)


def run(code):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, str(PAGE), "exec"), {})
    return out.getvalue().splitlines()


def test_every_block_of_the_pyelastica_page_runs_and_prints_what_it_says():
    code = blocks()
    assert len(code) == 5
    # 1: the cantilever's sag against Euler-Bernoulli, short by 1/(3 N^2) at N = 10
    (ratio,) = run(code[0])
    assert abs(float(ratio) - 0.99666) < 1e-5, ratio
    # 2: the root holds P up and the moment P L; the moment inside is P (L - s)
    lines = run(code[1])
    root = np.array(lines[0].strip("[]").split(), dtype=float)
    np.testing.assert_allclose(root, [0, 0, 0.01, 0, -0.002, 0], atol=1e-8)
    # 3: ten calls
    assert run(code[2]) == ["10"]
    # 4 and 5 run
    run(code[3])
    run(code[4])
