"""The fuzz suite (issue 12): a seeded generator of mutated inputs, run in two tiers.

* fast tier (``tests/fuzz/test_fuzz_fast.py``, collected by plain ``pytest``): a few hundred cases through
  the loaders in-process, validation only, a timeout per case;
* full tier (``python -m tests.fuzz.run --n 1000``): every case through the command line in a subprocess
  with a timeout; counts per class printed and written to a JSON file.
"""
