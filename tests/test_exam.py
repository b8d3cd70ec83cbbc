"""gfxlab.exam: every numeric answer checked against values derived here, independently."""

import subprocess
import sys
from fractions import Fraction

import matplotlib
import numpy as np
import pytest

from gfxlab import exam
from gfxlab.__main__ import main as gfxlab_main

matplotlib.use("Agg")

SEED_BLOCK = np.array(
    [
        [-76, -73, -67, -62, -58, -67, -64, -55],
        [-65, -69, -73, -38, -19, -43, -59, -56],
        [-66, -69, -60, -15, 16, -24, -62, -55],
        [-65, -70, -57, -6, 26, -22, -58, -59],
        [-61, -67, -60, -24, -2, -40, -60, -58],
        [-49, -63, -68, -58, -51, -60, -70, -53],
        [-43, -57, -64, -69, -73, -67, -63, -45],
        [-41, -49, -59, -60, -63, -52, -50, -34],
    ],
    float,
)
# ITU-T T.81 Table K.1
LUMA = np.array(
    [
        [16, 11, 10, 16, 24, 40, 51, 61],
        [12, 12, 14, 19, 26, 58, 60, 55],
        [14, 13, 16, 24, 40, 57, 69, 56],
        [14, 17, 22, 29, 51, 87, 80, 62],
        [18, 22, 37, 56, 68, 109, 103, 77],
        [24, 35, 55, 64, 81, 104, 113, 92],
        [49, 64, 78, 87, 103, 121, 120, 101],
        [72, 92, 95, 98, 112, 100, 103, 99],
    ],
    float,
)


def test_registry_covers_every_seed_question():
    expected = [f"Q{s}{c}" for s in "12345" for c in "abcdef"]
    assert list(exam.QUESTIONS) == expected
    assert all(q.marks == 5 for q in exam.QUESTIONS.values())
    assert sum(q.marks for q in exam.QUESTIONS.values()) == 150  # 30 questions, any three of six
    numeric = {q.id for q in exam.QUESTIONS.values() if q.numeric}
    assert {"Q1b", "Q1f", "Q2a", "Q2b", "Q2c", "Q2f", "Q3d", "Q4f", "Q5c", "Q5f"} <= numeric


@pytest.mark.parametrize("qid", list(exam.QUESTIONS))
def test_every_answer_renders(qid):
    answer = exam.solve(qid)
    text, markdown = answer.to_text(), answer.to_markdown()
    assert qid in text and qid in markdown
    assert answer.summary and answer.see_also and "gfxlab" in answer.see_also
    if exam.QUESTIONS[qid].numeric:
        assert len(answer.steps) >= 3
    if answer.figure is not None:
        import matplotlib.pyplot as plt

        fig = answer.figure()
        assert fig.axes
        plt.close(fig)


def _midpoint_trace(r):
    """Hearn and Baker's steps, written out plainly: (k, p_k, x_{k+1}, y_{k+1})."""
    x, y, p, rows = 0, r, 1 - r, []
    while x < y:
        p_k = p
        x += 1
        if p_k < 0:
            p = p_k + 2 * x + 1
        else:
            y -= 1
            p = p_k + 2 * x + 1 - 2 * y
        rows.append((len(rows), p_k, x, y))
    return rows


def test_q1b_radius_0_is_the_documented_single_pixel_and_counts_in_the_singular(capsys):
    """`midpoint_circle(0)` is documented as the single centre pixel; the answer says so
    ("1 distinct pixel", not "1 distinct pixels") and its other counts stay plural."""
    answer = exam.solve("Q1b", radius=0)
    np.testing.assert_array_equal(answer.values["pixels"], [[0, 0]])
    assert len(answer.values["trace"]) == 0
    assert gfxlab_main(["exam", "Q1b", "--set", "radius=0"]) == 0
    out = capsys.readouterr().out
    assert "1 distinct pixel in all." in out and "pixels in all" not in out
    assert "the single pixel (0, 0)" in out
    assert gfxlab_main(["exam", "Q1b", "--set", "radius=1"]) == 0
    pixels = len(exam.solve("Q1b", radius=1).values["pixels"])
    assert pixels > 1 and f"{pixels} distinct pixels in all." in capsys.readouterr().out


@pytest.mark.parametrize("radius", [10, 7, 23])
def test_q1b_trace(radius):
    trace = exam.solve("Q1b", radius=radius).values["trace"]
    np.testing.assert_array_equal(trace, _midpoint_trace(radius))
    if radius == 10:
        assert [tuple(r[2:]) for r in trace] == [
            (1, 10),
            (2, 10),
            (3, 10),
            (4, 9),
            (5, 9),
            (6, 8),
            (7, 7),
        ]
        assert trace[0][1] == -9


def test_q1f_codes_and_walkthrough():
    answer = exam.solve("Q1f")
    codes = answer.values["region_codes"]
    np.testing.assert_array_equal(
        codes, [[0b1001, 0b0001, 0b0101], [0b1000, 0, 0b0100], [0b1010, 0b0010, 0b0110]]
    )
    ad, ei = answer.values["AD"], answer.values["EI"]
    assert [s["action"] for s in ad] == ["clip", "accept"] and ad[0]["edge"] == "top"
    assert [s["edge"] for s in ei[:3]] == ["bottom", "top", "right"]
    assert ei[-1]["action"] == "accept"


def test_q2a_matrix():
    window, viewport = (1.0, 1.0, 5.0, 4.0), (0.0, 0.0, 320.0, 120.0)
    sx, sy = 320 / 4, 120 / 3
    expected = np.array([[sx, 0, 0 - sx * 1], [0, sy, 0 - sy * 1], [0, 0, 1]])
    np.testing.assert_allclose(
        exam.solve("Q2a", window=window, viewport=viewport).values["matrix"], expected
    )


def test_q2b_vertices_both_conventions():
    t = np.array([[1, 0, 0], [0, 1, 0], [1, 1, 1]], float)  # row-vector translation
    r = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]], float)  # row-vector rotation by 90 degrees
    square = np.array([[-0.5, -0.5, 1], [0.5, -0.5, 1], [0.5, 0.5, 1], [-0.5, 0.5, 1]])
    expected = (square @ t @ r)[:, :2]
    answer = exam.solve("Q2b")
    np.testing.assert_allclose(answer.values["vertices"], expected, atol=1e-15)
    np.testing.assert_allclose(expected[1], [-0.5, 1.5])
    np.testing.assert_allclose(answer.values["matrix"].T, t @ r, atol=1e-15)


def test_q2c_closed_form():
    values = exam.solve("Q2c", factors=(3.0, 0.5), center=(2.0, 7.0)).values
    np.testing.assert_allclose(values["composed"], [[3, 0, -4], [0, 0.5, 3.5], [0, 0, 1]])


def test_q2f_vertices():
    t = np.array([[1, 1.5, 3], [0.8, 0, 1], [0.5, 1, 1]])
    cube = np.array(
        [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
        float,
    )
    np.testing.assert_allclose(exam.solve("Q2f").values["vertices"], cube @ t)
    np.testing.assert_allclose(exam.solve("Q2f").values["vertices"][6], [1.8, 1.5, 4.0])


def test_q3d_photometry():
    import colour

    values = exam.solve("Q3d").values
    assert values["peak_nm"] == 555
    table = {name: float(eff) for name, _, eff in values["sources"]}
    assert table["1 W laser at 555 nm"] == pytest.approx(683, rel=1e-3)
    # colour-science is the independent source of V(lambda).
    v = colour.colorimetry.SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    assert table["1 W laser at 650 nm (red)"] == pytest.approx(683 * v[650], rel=2e-3)
    assert 14 < table["blackbody 2856 K (CIE illuminant A), all wavelengths"] < 18


def test_q4f_bezier_exact_fractions():
    control = [
        (Fraction(1), Fraction(1)),
        (Fraction(2), Fraction(3)),
        (Fraction(4), Fraction(3)),
        (Fraction(6), Fraction(4)),
    ]
    us = [Fraction(0), Fraction(1, 4), Fraction(1, 2), Fraction(3, 4), Fraction(1)]

    def point(u):
        w = [(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u**2 * (1 - u), u**3]
        return tuple(sum(wi * c[i] for wi, c in zip(w, control, strict=True)) for i in (0, 1))

    expected = np.array([[float(c) for c in point(u)] for u in us])
    np.testing.assert_allclose(exam.solve("Q4f").values["points"], expected, atol=1e-15)
    assert point(Fraction(1, 4)) == (Fraction(123, 64), Fraction(139, 64))
    assert "123/64" in exam.solve("Q4f").to_text()


def test_q5c_medians():
    values = exam.solve("Q5c").values
    block = np.array([91, 55, 90, 77, 68, 95, 115, 151, 210])
    assert values["full"] == np.median(block) == 91
    assert values["cross"] == np.median([55, 77, 68, 95, 151]) == 77
    assert values["even"] == (68 + 77) / 2


def _zigzag_order(n=8):
    order = []
    for s in range(2 * n - 1):
        diagonal = [(i, s - i) for i in range(n) if 0 <= s - i < n]
        order += diagonal if s % 2 else diagonal[::-1]
    return order


def test_q5f_dct_quantization_zigzag():
    values = exam.solve("Q5f").values
    k = np.arange(8)
    alpha = np.where(k == 0, np.sqrt(1 / 8), np.sqrt(2 / 8))
    basis = alpha[:, None] * np.cos((2 * k[None, :] + 1) * k[:, None] * np.pi / 16)
    dct = basis @ SEED_BLOCK @ basis.T
    np.testing.assert_allclose(values["dct"], dct, atol=1e-9)
    quantized = np.round(dct / LUMA).astype(int)
    np.testing.assert_array_equal(values["quantized"], quantized)
    assert quantized[0, 0] == -26
    sequence = [quantized[i, j] for i, j in _zigzag_order()]
    last = max(i for i, v in enumerate(sequence) if v != 0)
    np.testing.assert_array_equal(values["zigzag"], sequence[: last + 1])
    assert sequence[:10] == [-26, -3, 0, -3, -2, -6, 2, -4, 1, -3]


def test_errata_are_stated():
    found = exam.errata()
    text = {qid: " ".join(e for q, e in found if q == qid) for qid in exam.QUESTIONS}
    assert "(-1/2, 3/2)" in text["Q2b"]
    assert "(1, 1, 0)" in text["Q2f"] and "V'" in text["Q2f"]
    assert "six of its eight rows" in text["Q5f"]
    assert "LTRB" in text["Q1f"] and "LRBT" in text["Q1f"]


def test_question_lookup():
    assert exam.question("q4f").id == "Q4f"
    with pytest.raises(KeyError, match="no question"):
        exam.question("Q9z")
    with pytest.raises(TypeError):
        exam.solve("Q2b", radius=3)


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "gfxlab", "exam", *args], capture_output=True, text=True
    )


def test_cli_lists_prints_and_writes_markdown(tmp_path, capsys):
    # The real command once (`python -m gfxlab exam`), then the same `main` in this process:
    # each further interpreter would only import JAX and gfxlab again.
    listing = _cli()
    assert listing.returncode == 0
    assert all(qid in listing.stdout for qid in exam.QUESTIONS)

    def run(*args):
        code = gfxlab_main(["exam", *args])
        out, err = capsys.readouterr()
        return code, out, err

    code, out, _ = run("Q1b", "--set", "radius=5")
    assert code == 0 and "p0 = 1 - r = -4" in out
    code, out, _ = run("Q2a")
    assert code == 0 and "Step 1. Translate the window corner" in out
    assert "Step 1. 1." not in out
    markdown = tmp_path / "q2b.md"
    code, _, _ = run("Q2b", "--markdown", str(markdown))
    assert code == 0 and "\\begin{pmatrix}" in markdown.read_text()
    code, _, err = run("Q7a")
    assert code == 2 and "no question" in err
    # a student's mistakes: a clear message and status 2, never a traceback
    code, out, _ = run()
    assert code == 0 and "Q1b" in out and "(--set radius)" in out  # the options are listed
    for args, message in [
        (("Q1b", "--set", "radius=-3"), "bad option for Q1b: `radius` must be >= 0"),
        (("Q1b", "--set", "radius=100000"), "bad option for Q1b: `radius` must be <="),
        (("Q1b", "--set", "foo=1"), "Q1b has no option 'foo' (its options: radius)"),
        (("all", "--set", "radius=5"), "--set applies to one question"),
        (("Q2b", "--markdown", str(tmp_path / "no dir" / "q 2b.md")), "cannot write"),
    ]:
        code, _, err = run(*args)
        assert code == 2 and message in err, (args, err)
    with pytest.raises(SystemExit) as exit_info:  # argparse: usage and status 2
        run("--set", "radius=3")
    assert exit_info.value.code == 2 and "--set needs a question id" in capsys.readouterr().err


@pytest.fixture
def x64_off():
    """The caller's process in JAX's default float32 mode (the test suite runs in float64)."""
    import jax

    jax.config.update("jax_enable_x64", False)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", True)


@pytest.mark.parametrize("call", ["solve", "figure", "errata"])
def test_exam_leaves_the_callers_x64_setting_alone(x64_off, call):
    import jax
    import jax.numpy as jnp
    import matplotlib.pyplot as plt

    assert jax.config.jax_enable_x64 is False
    if call == "solve":
        values = exam.solve("Q5f").values
        # Still computed in float64 inside: the DCT matches NumPy to float64 precision.
        k = np.arange(8)
        alpha = np.where(k == 0, np.sqrt(1 / 8), np.sqrt(2 / 8))
        basis = alpha[:, None] * np.cos((2 * k[None, :] + 1) * k[:, None] * np.pi / 16)
        np.testing.assert_allclose(values["dct"], basis @ SEED_BLOCK @ basis.T, atol=1e-9)
    elif call == "figure":
        plt.close(exam.solve("Q4f").figure())
    else:
        assert exam.errata()
    assert jax.config.jax_enable_x64 is False
    assert jnp.ones(1).dtype == jnp.float32


def test_exam_keeps_x64_on_when_the_caller_set_it():
    import jax

    assert jax.config.jax_enable_x64 is True
    exam.solve("Q2a")
    assert jax.config.jax_enable_x64 is True


@pytest.mark.parametrize("qid", [q for q, item in exam.QUESTIONS.items() if item.numeric])
def test_step_titles_are_not_numbered_twice(qid):
    import re

    for line in exam.solve(qid).to_text().splitlines():
        assert not re.match(r"Step \d+\. \d+\. ", line), line


def test_dct_figure_colour_maps_are_centred_at_zero():
    import matplotlib.pyplot as plt

    fig = exam.solve("Q5f").figure()
    try:
        images = [ax.images[0] for ax in fig.axes if ax.images]
        assert len(images) == 3
        for im in images:
            low, high = im.get_clim()
            assert low == -high and high > 0
            assert im.get_cmap().name == "RdBu_r"
    finally:
        plt.close(fig)


def test_question_bad_ids():
    with pytest.raises(TypeError, match="`qid`"):
        exam.question(None)
    with pytest.raises(TypeError, match="`qid`"):
        exam.solve(3)
    with pytest.raises(KeyError, match="no question ''"):
        exam.question("")


def test_public_namespace_is_flat():
    import gfxlab.exam as package

    assert set(package.__all__) == {
        "Question",
        "Answer",
        "Step",
        "Table",
        "QUESTIONS",
        "question",
        "solve",
        "errata",
        "main",
    }
    assert all(hasattr(package, name) for name in package.__all__)
    assert isinstance(package.QUESTIONS["Q1a"], package.Question)
