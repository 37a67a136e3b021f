"""advise.check and advise.Operators: the language's check and interpreter from Python."""

import numpy as np
import pytest

import advise

CREEP = """/// Creep forward.
operator creep(speed = 0.1 in [0, 1]) for positioning on action {
    trans = speed
}
"""


def test_check_accepts_the_standard_files_and_text():
    assert advise.check("operators/positioning.adv") == []
    assert advise.check(CREEP) == []


def test_check_raises_with_coded_diagnostics():
    with pytest.raises(advise.AdviseError) as e:
        advise.check("operator x for positioning on action { trans = nope }")
    err = e.value
    assert err.code == "advise::check::unknown_name"
    d = err.diagnostics[0]
    assert isinstance(d, advise.Diagnostic)
    assert d.code == err.code and "nope" in d.message
    assert d.span.file == "<text>" and d.span.line == 1 and d.span.column == 48
    assert d.help and "trans" in d.help
    assert "advise::check::unknown_name" in d.rendered


def test_apply_slow_down_on_arrays():
    ops = advise.Operators()
    assert "slow_down" in ops.names("positioning")
    z = np.array([[4.0, 0.1, 0.2], [3.0, 0.0, 0.1], [2.0, -0.1, 0.0]])
    a = np.array([[0.8, 0.2], [0.6, -0.1], [0.4, 0.0]])
    zs, as_, skipped = ops.apply("slow_down", {"rate": 0.5}, z, a, task="positioning")
    assert zs.shape == (3, 3) and as_.shape == (3, 2)
    assert skipped.dtype == bool and not skipped.any()
    assert np.array_equal(zs, z)
    assert np.allclose(as_[:, 0], a[:, 0] * 0.5)


def test_operators_from_text_and_a_chunk():
    ops = advise.Operators(CREEP)
    z = np.zeros((5, 3)) + [1.0, 0.0, 0.0]
    a = np.zeros((5, 2))
    zs, as_, skipped = ops.apply("creep", {"speed": 0.25}, z, a, domain="positioning", chunk=(1, 4))
    assert as_.shape == (3, 2) and np.all(as_[:, 0] == 0.25)
    assert skipped.shape == (3,)


@pytest.mark.parametrize(
    "call, code",
    [
        (lambda o, z, a: o.apply("no_such_op", {}, z, a, task="positioning"), "advise::check::"),
        (lambda o, z, a: o.apply("slow_down", {}, z[:, :2], a, task="positioning"), "advise::py::shape"),
        (lambda o, z, a: o.apply("slow_down", {}, z * np.nan, a, task="positioning"), "advise::py::not_finite"),
        (lambda o, z, a: o.apply("slow_down", {}, z, a, domain="nowhere"), "advise::py::unknown_domain"),
        (lambda o, z, a: o.apply("slow_down", {}, z, a), "advise::py::domain_or_task"),
        (lambda o, z, a: o.apply("slow_down", {}, z, a, task="positioning", chunk=(2, 9)), "advise::"),
    ],
)
def test_bad_inputs_raise_coded_errors(call, code):
    ops = advise.Operators()
    z, a = np.ones((3, 3)), np.zeros((3, 2))
    with pytest.raises(advise.AdviseError) as e:
        call(ops, z, a)
    assert e.value.code.startswith(code), e.value.code
