"""The studies as functions: ``advise.study`` / ``advise.studies`` return what
``advise experiment STUDY --seed SEED --json`` prints, and refuse what the command line refuses."""

import pytest

import advise


def test_the_bc_study_is_the_command_lines(experiment_cli):
    assert advise.studies.bc(2, critique="paper", teacher="hand") == experiment_cli(
        "bc", "--seed", "2", "--critique", "paper", "--teacher", "hand")


# The A-OPI study's arms are capped at 3 practice goals (`--practice`): a whole seed takes
# minutes since the kernel is tuned over whole held-out demonstrations (issue 48), 10 goals about
# 17 s in the tests' build against 4 s, and the equality is the same one: every arm runs, is
# evaluated and reported.
def test_the_aopi_study_is_the_command_lines(experiment_cli):
    assert advise.studies.aopi(1, practice=3) == experiment_cli("aopi", "--seed", "1", "--practice", "3")


def test_a_reverted_choice_is_the_command_lines(experiment_cli):
    assert advise.study("bc", 1, revert="ball", critique="paper") == experiment_cli(
        "bc", "--seed", "1", "--revert", "ball", "--critique", "paper")
    assert advise.studies.aopi(2, revert="advisor", practice=3) == experiment_cli(
        "aopi", "--seed", "2", "--revert", "advisor", "--practice", "3")


def test_bad_arguments_raise_coded_errors():
    for call in (lambda: advise.study("abc", 0),
                 lambda: advise.studies.aopi(0, revert="ball"),
                 lambda: advise.study("aopi", 0, critique="paper"),
                 lambda: advise.study("bc", 0, practice=10),
                 lambda: advise.studies.aopi(0, practice=0),
                 lambda: advise.studies.bc(0, critique="sideways"),
                 lambda: advise.study("aopi", 0, teacher="hand"),
                 lambda: advise.studies.bc(0, teacher="robot")):
        with pytest.raises(advise.AdviseError) as e:
            call()
        assert e.value.code == "advise::py::bad_argument"
    with pytest.raises(advise.AdviseError) as e:
        advise.studies.bc(0, sim_params="/nonexistent/sim.json")
    assert e.value.code.startswith("advise::")
