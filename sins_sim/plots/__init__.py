"""All matplotlib figures of sins-sim, one module per job.

matplotlib is imported lazily inside the plotting functions (Agg backend), so
``import sins_sim`` and every engine import stay free of it.

* :mod:`~sins_sim.plots.common`: channel and scenario figures;
* :mod:`~sins_sim.plots.paper`: the paper's figures for ``sins-sim reproduce``.
"""
