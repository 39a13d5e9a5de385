# Convenience targets; CI runs .ci/run.
.PHONY: docs docs-clean

# The documentation, warnings as errors; the examples run (a failing one fails the build).
docs:
	python -m sphinx -W --keep-going -b html docs docs/_build/html

docs-clean:
	rm -rf docs/_build docs/gallery docs/getting-started/tutorial docs/reference/api docs/sg_execution_times.rst
