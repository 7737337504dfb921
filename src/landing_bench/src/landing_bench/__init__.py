"""Graph and speed benches of the landing system: the simulator alone (bench_sim), the closed loop (bench_loop),
its graph floor of null nodes (graph_floor, null_node, bus_stats), sweeps locally and on Ray (ray_scaling), and the
detector's frames rendered by the simulator (rendered_frames, rendered_benchmark). Uses landing_eval's public
modules (isolated_ros, processes, run_pool, ray_local); landing_eval never imports this package."""
