"""The camera's renderer thread: a frame shows the world of its capture, whatever the physics did since."""
import concurrent.futures
import os
import threading

import mujoco
import numpy as np

from mujoco_sim.frame_renderer import DeliveredFrames, FrameRenderer
from test_simulator import airborne, make_sim, run


def _moving_world(realism):
    sim = make_sim(realism=realism)
    sim.set_vehicle_command(1.0, 0.3)
    airborne(sim)
    return sim


def _raw(sim, renderer=None):
    """The frame of sim's present state rendered on the spot, undeveloped (no lens, exposure or noise)."""
    renderer.update_scene(sim.data, camera=sim.camera, scene_option=sim._renderer.scene_option)
    return renderer.render()


def test_a_snapshot_renders_the_same_pixels_as_the_live_state():
    sim = _moving_world("harsh")  # shadows: the drone's geoms are in the scene too
    sim.render_camera()  # opens the camera
    threaded = FrameRenderer(mujoco, sim.model, sim.camera, 240, 320, sim._renderer.scene_option,
                             lambda image, job: image)
    direct = mujoco.Renderer(sim.model, 240, 320)
    try:
        for _ in range(5):
            run(sim, 0.3, command=(0.5, 0.2, 0.3, 0.2))
            assert np.array_equal(threaded.render_now(sim.data, None), _raw(sim, direct))
    finally:
        threaded.close()
        direct.close()
        sim.close()


def test_a_frame_shows_its_capture_instant_while_the_physics_steps_on():
    sim = _moving_world("ideal")
    sim.render_camera()
    direct = mujoco.Renderer(sim.model, 240, 320)
    try:
        expected = sim._develop(_raw(sim, direct), (None, sim.time, 0.0))
        frame = sim.capture_camera()
        run(sim, 0.5, command=(1.0, 0.0, 0.5, 0.5))  # the world moves on while the frame renders
        later = sim._develop(_raw(sim, direct), (None, sim.time, 0.0))
        assert not np.array_equal(expected, later)
        assert np.array_equal(frame.result(timeout=30), expected)
        # the thread that rendered it, whose priority the simulator raises while it steps (scheduling)
        assert sim.camera_thread_id() not in (None, threading.get_native_id())
        assert os.path.exists("/proc/self/task/%d" % sim.camera_thread_id())
    finally:
        direct.close()
        sim.close()


def test_frames_in_flight_come_out_as_rendered_one_by_one():
    """Several frames captured before the first is read (a link's latency) develop with the same random
    draws (exposure wander, pixel noise), in capture order, as frames rendered and read one at a time."""
    at_once, one_by_one = _moving_world("harsh"), _moving_world("harsh")
    try:
        frames, images = [], []
        for _ in range(6):
            frames.append(at_once.capture_camera(noise_std=0.02))
            images.append(one_by_one.render_camera(noise_std=0.02))
            run(at_once, 0.1)
            run(one_by_one, 0.1)
        for frame, image in zip(frames, images):
            assert np.array_equal(frame.result(timeout=30), image)
        assert not np.array_equal(images[0], images[-1])
    finally:
        at_once.close()
        one_by_one.close()


def test_delivered_frames_go_out_in_order_as_they_are_ready_and_all_before_time_moves_on():
    sent = []
    frames = [concurrent.futures.Future() for _ in range(3)]
    delivered = DeliveredFrames()
    for number, frame in enumerate(frames):
        delivered.add(frame, lambda image, number=number: sent.append((number, image)))
    frames[1].set_result("second")
    delivered.publish_ready(wait=False)
    assert sent == []  # the second is ready, but the first is not: the order holds
    frames[0].set_result("first")
    delivered.publish_ready(wait=False)
    assert sent == [(0, "first"), (1, "second")] and len(delivered) == 1
    threading.Timer(0.05, frames[2].set_result, ["third"]).start()
    assert delivered.publish_ready(wait=True) > 0.0  # before a clock tick: waits for the frame still rendering
    assert sent[-1] == (2, "third") and len(delivered) == 0
