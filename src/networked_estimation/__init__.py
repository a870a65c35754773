"""networked_estimation from Python: the package's estimators, lossy links, simulator, stability
analysis and Monte Carlo, over its C++ core (docs/python.md).

    import networked_estimation as ne
    model = ne.Model.from_yaml("config/models/zhou_example.yaml")
    sim = ne.simulate(model, ne.GilbertElliott(p=0.1, r=0.5), steps=1000, seed=1)
    x, P, trace = ne.make_estimator(model, "kfio").run(sim["y"], sim["gamma"])

Every function is a thin binding of the C++ core (the module _core); nothing is computed in Python.
The generated ROS messages and services stay where ROS puts them (networked_estimation.msg, .srv).
"""

from pkgutil import extend_path

# Every folder of the package on sys.path (a catkin workspace splits it: these files in the source
# space, the compiled _core and the messages in the devel space).
__path__ = extend_path(__path__, __name__)

# The ROS tools (rostopic, rosservice) import this package for its messages and services: they must
# not need the compiled module, which a build of only the nodelets (scripts/demo.sh) leaves out.
try:
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
        fit_link,
        load_replay_input,
        make_estimator,
        merge,
        montecarlo,
        score,
        simulate,
        verdict,
    )
except ImportError as error:
    _core_problem = str(error)

    def __getattr__(name):
        if name in __all__:
            raise ImportError("networked_estimation.%s: the compiled module networked_estimation._core is not "
                              "available (%s): build it with the package (scripts/build.sh, or catkin_make)"
                              % (name, _core_problem))
        raise AttributeError("module 'networked_estimation' has no attribute '%s'" % name)
else:
    def _by_name(function):
        """A Python function calling the binding `function`, so that it pickles by its name (dask's
        workers call networked_estimation.montecarlo; a binding's own object does not pickle)."""
        def call(*args, **kwargs):
            return function(*args, **kwargs)
        call.__name__ = call.__qualname__ = function.__name__
        call.__doc__ = function.__doc__
        call.__module__ = __name__
        call.__wrapped__ = function  # help() and inspect show the binding's own signature
        return call

    Bernoulli, GilbertElliott, Sensor = _by_name(Bernoulli), _by_name(GilbertElliott), _by_name(Sensor)
    analyze, design, experiment_names = _by_name(analyze), _by_name(design), _by_name(experiment_names)
    fit_link = _by_name(fit_link)
    load_replay_input, make_estimator = _by_name(load_replay_input), _by_name(make_estimator)
    merge, montecarlo = _by_name(merge), _by_name(montecarlo)
    score, simulate, verdict = _by_name(score), _by_name(simulate), _by_name(verdict)

__all__ = [
    "DivergenceError", "Estimator", "Link", "Bernoulli", "GilbertElliott", "Model", "MonteCarloResult",
    "Sensor", "Shard", "analyze", "design", "experiment_names", "fit_link", "load_replay_input", "make_estimator",
    "merge", "montecarlo", "score", "simulate", "verdict",
]
