"""The listed fuzz families (issue 40), every case in-process: the block section, online filter parameters, coning
choices with each filter, ``navigate``, ``--force`` with foreign files and effect parameters.

Each case is judged as in the fast tier (``harness.judge``); every class must end with 0 tracebacks, 0 silent
acceptances, 0 valid inputs refused, 0 refusals naming no field and 0 refusals in the code's words (``internal``:
``__init__``, "unexpected keyword argument", ...). The families are fixed lists, so all of them run (about 150
cases, validation only); the seeded tiers draw from the same lists.
"""

from __future__ import annotations

import importlib
import random

import pytest

from .families import families
from .generate import Case
from .harness import internal_words, judge, run_in_process, summarize

LISTED = ("block_section", "online_parameters", "coning_choice", "navigate_inputs", "force_foreign",
          "effect_parameters")
#: As the fast tier (tests/fuzz/test_fuzz_fast.py): a hang, not a slow case.
TIMEOUT_S = 30.0


def _cases():
    out = []
    for kind in LISTED:
        module = importlib.import_module(f".families.{kind}", package=__package__)  # as the imports above: no "tests." (CI has no checkout on sys.path)
        for k, make in enumerate(module.CASES):
            m = make()
            out.append(Case(f"{kind}-{k:03d}", kind, m.cls, m.expect, m.what, dict(m.files), m.main, gap=m.gap,
                            family=kind))
    return out


@pytest.fixture(scope="module")
def results():
    return [run_in_process(case, timeout=TIMEOUT_S) for case in _cases()]


def test_every_listed_case_validates_or_is_refused_in_the_users_words(results):
    summary = summarize(results)
    listing = "\n".join(f"{f['id']} ({f['what']}): {f['verdict']}: {f['message'][:240]}" for f in summary["failures"])
    assert not summary["failures"], listing


def test_every_listed_class_has_cases_of_its_kind_and_both_outcomes(results):
    fams = families()
    for kind in LISTED:
        classes = {r.cls for r in results if r.kind == kind}
        assert classes == set(fams[kind].classes), kind
        assert any(r.outcome == "accepted" for r in results if r.kind == kind), kind
        assert any(r.outcome == "refused" for r in results if r.kind == kind), kind


def test_the_seeded_generator_draws_from_the_lists():
    for kind in LISTED:
        made = families()[kind].make(random.Random(7))
        assert made.cls in families()[kind].classes


@pytest.mark.parametrize(("message", "word"), [
    ("effects[0]: AxisCoupling.__init__() got an unexpected keyword argument 'coefficient'", "__init__"),
    ("navigation.coning: filters.lms_stripper: a three-axis filter; only the SINS engine runs it",
     "only the SINS engine"),
    ("unsupported format string passed to NoneType.__format__", "NoneType"),
    ("navigation.coning: filter_tuned cannot go with the filter lms_stripper", None),
])
def test_internal_words_are_told_apart(message, word):
    assert internal_words(message) == word
    assert (judge("invalid", "refused", None, message) == "internal") == (word is not None)
