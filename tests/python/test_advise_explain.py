"""advise.BC/LWR's critique and why against the REPL's: the same demonstrations, the same run,
the same chunk critiqued give the same increments (to the bit), the same reply, and afterwards
the same actions; why gives the REPL's text."""

import numpy as np
import pytest

import advise

SCRIPT = """load demos demos.csv
learner bc
run goal 2 -1 0.5
select 10..30
critique 2
why 12
run goal 1.5 1 0
save out.json
"""


@pytest.fixture(scope="module")
def session(scripted_session):
    return scripted_session(SCRIPT, "critique")


def test_critique_equals_the_repls(session):
    d, out, saved, runs = session
    bc = advise.BC(task="positioning").fit_file(str(d / "demos.csv"))
    z, a = runs[0]
    assert np.array_equal(bc.predict(z), a)
    c = bc.critique(z, chunk=(10, 30), kappa=2.0, actions=a)
    assert isinstance(c, advise.Critique) and c.chunk == (10, 30) and c.rule == "paper"
    assert c.summary in out  # the REPL's reply, word for word
    want = saved["critiques"][0]["increments"]
    assert c.increments.tolist() == [inc for _, inc in want]
    for p, (prov, _) in zip(c.provenance, want):
        assert prov == {"demonstration": {"demo": p.id, "index": p.index}}
    m = bc.weights()
    assert np.array_equal(c.weights, m[c.points])
    assert (m > 1.0).sum() == len(set(c.points.tolist()))
    # After the critique, the BC policy acts as the REPL's second run did.
    z1, a1 = runs[1]
    assert np.array_equal(bc.predict(z1), a1)


def test_why_gives_the_repls_text(session):
    d, out, saved, runs = session
    bc = advise.BC(task="positioning").fit_file(str(d / "demos.csv"))
    z, a = runs[0]
    bc.critique(z, chunk=(10, 30), kappa=2.0, actions=a)
    w = bc.why(z[12])
    assert isinstance(w, advise.Why)
    # The BC part word for word. The LWR line differs: the REPL's learner ran as LWR before
    # `learner bc` and keeps the LWR parameters tuned then; a BC fitted here never tuned LWR,
    # and says so instead of reporting its untuned defaults' neighbourhood.
    bc_part = w.text.split("LWR:")[0]
    assert bc_part.startswith("nearest (BC): point ") and bc_part in out
    assert not w.lwr_tuned
    assert "LWR: not tuned on this data (the running learner is BC 1-NN; `learner lwr` tunes it)" in w.text
    assert w.provenance.kind == "demonstration" and w.provenance.name.startswith("demo-")
    assert w.weighted == pytest.approx(w.m * w.distance)
    assert w.action == w.bc_action
    lwr = advise.LWR(task="positioning").fit_file(str(d / "demos.csv"))
    assert np.array_equal(np.array([lwr.why(q).action for q in z[:5]]), lwr.predict(z[:5]))
    assert lwr.why(z[12]).lwr_tuned and "LWR: not tuned" not in lwr.why(z[12]).text


def test_bad_critiques_raise_coded_errors(session):
    d, *_ = session
    bc = advise.BC(task="positioning")
    with pytest.raises(advise.AdviseError) as e:
        bc.why(np.zeros(3))
    assert e.value.code == "advise::py::not_fitted"
    bc.fit_file(str(d / "demos.csv"))
    z = np.zeros((5, 3))
    for kwargs, code in [
        ({"kappa": -1.0}, "advise::session::bad_kappa"),
        ({"rule": "harsh"}, "advise::py::bad_argument"),
        ({"chunk": (3, 9)}, "advise::"),
    ]:
        with pytest.raises(advise.AdviseError) as e:
            bc.critique(z, **kwargs)
        assert e.value.code.startswith(code), (kwargs, e.value.code)
    with pytest.raises(advise.AdviseError) as e:
        bc.why(np.zeros(4))
    assert e.value.code == "advise::py::shape"

