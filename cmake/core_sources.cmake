# The ROS-free core's sources (the catkin build and the build without ROS, CMakeLists.txt).
set(NE_CORE_SOURCES
  # channel/: loss models and the lossy channel engine
  src/core/channel/channel.cpp
  src/core/channel/loss_model.cpp
  # config/: the checked-field reader (field), the YAML helpers and the three configuration files it reads; kinematic models
  # and the model file writer (make_model)
  src/core/config/channel_settings.cpp
  src/core/config/estimator_settings.cpp
  src/core/config/field.cpp
  src/core/config/kinematic_model.cpp
  src/core/config/model_config.cpp
  src/core/config/model_validation.cpp
  src/core/config/model_writer.cpp
  src/core/config/motion_config.cpp
  src/core/config/omni_model.cpp
  src/core/config/param_reader.cpp
  src/core/config/rate_schedule.cpp
  src/core/config/schedule_config.cpp
  src/core/config/sensor_links.cpp
  src/core/config/yaml_reader.cpp
  # estimators/: kf, kfio, rseio, aoe, oe, ack_kf, ekfio behind one Estimator interface
  src/core/estimators/aoe.cpp
  src/core/estimators/ekfio.cpp
  src/core/estimators/estimator_common.cpp
  src/core/estimators/estimator_factory.cpp
  src/core/estimators/kalman.cpp
  src/core/estimators/predict_ahead.cpp
  src/core/estimators/rseio.cpp
  src/core/estimators/step_covariance.cpp
  # experiments/: the Monte Carlo engine, its results and files, the experiments by name, and the
  # papers' experiments and models
  src/core/experiments/experiment_registry.cpp
  src/core/experiments/experiment_support.cpp
  src/core/experiments/experiments_covariance.cpp
  src/core/experiments/experiments_lin.cpp
  src/core/experiments/experiments_sinopoli.cpp
  src/core/experiments/experiments_sweep.cpp
  src/core/experiments/experiments_yang.cpp
  src/core/experiments/experiments_zhou.cpp
  src/core/experiments/montecarlo_engine.cpp
  src/core/experiments/montecarlo_output.cpp
  src/core/experiments/montecarlo_shards.cpp
  src/core/experiments/paper_models.cpp
  src/core/experiments/quantile_sketch.cpp
  src/core/experiments/shard_file.cpp
  src/core/experiments/sweep_analysis.cpp
  src/core/experiments/sweep_axes.cpp
  src/core/experiments/sweep_output.cpp
  # geodesy/: latitude/longitude to local ENU (GeographicLib)
  src/core/geodesy/local_enu.cpp
  src/core/geodesy/navsat_alignment.cpp
  # io/: the tools' CSV and JSON files, ROS bags' headers, scoring, atomic output files
  src/core/io/arrival_trace.cpp
  src/core/io/atomic_file.cpp
  src/core/io/csv_cells.cpp
  src/core/io/json_document.cpp
  src/core/io/json_writer.cpp
  src/core/io/replay_csv_read.cpp
  src/core/io/replay_csv_write.cpp
  src/core/io/ros_bag.cpp
  src/core/io/score.cpp
  # link/: a recorded link (bags, trace CSVs) and its loss and delay fits (fit_link, analyze --bag), the
  # link estimates the live monitors share with them, the trace-driven channel (model: trace)
  src/core/link/channel_trace.cpp
  src/core/link/delay_fit.cpp
  src/core/link/link_estimates.cpp
  src/core/link/link_fit.cpp
  src/core/link/link_report.cpp
  src/core/link/link_trace.cpp
  src/core/link/measured_links.cpp
  # motion/: the built-in robot motions omni_2d and omni_3d, and their linearisation
  src/core/motion/linearised_model.cpp
  src/core/motion/motion.cpp
  # online/: deadline-driven sample assembly and the Estimator nodelet's configuration
  src/core/online/estimator_node_config.cpp
  src/core/online/latency_budget.cpp
  src/core/online/motion_sensors.cpp
  src/core/online/online_estimator.cpp
  src/core/online/online_estimator_inputs.cpp
  src/core/online/online_stream.cpp
  src/core/online/runtime_settings.cpp
  src/core/online/sensor_inputs.cpp
  src/core/online/sensor_lattice.cpp
  src/core/online/set_pose.cpp
  src/core/online/timeline.cpp
  # simulation/: the plant simulator
  src/core/simulation/lossy_run.cpp
  src/core/simulation/schedule_sampler.cpp
  src/core/simulation/sensor_outputs.cpp
  src/core/simulation/simulator.cpp
  # stability/: critical rates, verdicts, the live link monitor
  src/core/stability/analysis_json.cpp
  src/core/stability/analysis_text.cpp
  src/core/stability/eigen_structure.cpp
  src/core/stability/estimator_theorems.cpp
  src/core/stability/exact_schedules.cpp
  src/core/stability/exact_test.cpp
  src/core/stability/excitation.cpp
  src/core/stability/joint_link_monitor.cpp
  src/core/stability/link_design.cpp
  src/core/stability/link_model.cpp
  src/core/stability/link_monitor.cpp
  src/core/stability/live_stability.cpp
  src/core/stability/mare.cpp
  src/core/stability/sensor_margins.cpp
  src/core/stability/set_verdict.cpp
  src/core/stability/stability_report.cpp
  src/core/stability/yang_bounds.cpp
)
