// Monte Carlo experiments of the `montecarlo` tool (ROS-free), in three parts:
//   montecarlo_engine.hpp    the engine: runs in blocks, moments, heavy-tail statistics, sessions
//   experiment_result.hpp    the result of an experiment and its CSV and JSON files
//   experiment_registry.hpp  the experiments by name, their configuration and runExperiment
#pragma once

#include "networked_estimation/experiments/experiment_registry.hpp"
#include "networked_estimation/experiments/experiment_result.hpp"
#include "networked_estimation/experiments/montecarlo_engine.hpp"
