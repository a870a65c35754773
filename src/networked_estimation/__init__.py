"""networked_estimation from Python: the package's estimators, lossy links, simulator, stability
analysis and Monte Carlo, over its C++ core (docs/python.md).

    import networked_estimation as ne
    model = ne.Model.from_yaml("config/models/zhou_example.yaml")
    sim = ne.simulate(model, ne.GilbertElliott(p=0.1, r=0.5), steps=1000, seed=1)
    x, P, trace = ne.make_estimator(model, "kfio").run(sim["y"], sim["gamma"])

Every function is a thin binding of the C++ core (the module _core); nothing is computed in Python.
The generated ROS messages and services stay where ROS puts them (networked_estimation.msg, .srv).
"""

from ._core import (  # noqa: F401
    DivergenceError,
    Estimator,
    Link,
    Bernoulli,
    GilbertElliott,
    Model,
    MonteCarloResult,
    Sensor,
    Shard,
    analyze,
    design,
    experiment_names,
    load_replay_input,
    make_estimator,
    merge,
    montecarlo,
    score,
    simulate,
)

__all__ = [
    "DivergenceError", "Estimator", "Link", "Bernoulli", "GilbertElliott", "Model", "MonteCarloResult",
    "Sensor", "Shard", "analyze", "design", "experiment_names", "load_replay_input", "make_estimator",
    "merge", "montecarlo", "score", "simulate",
]
