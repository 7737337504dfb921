"""The bottom camera's renderer in a thread of its own, ROS-free.

A frame is captured at one instant of the physics and delivered later (the camera link's latency, 0.1-0.2 s
in the realistic and harsh worlds): rendering it (5 ms of CPU a frame with shadows, llvmpipe) need not hold
the physics meanwhile. ``capture`` copies the part of the state a render reads (the poses of every body, geom,
camera and light, which mj_step left in MjData) into a snapshot and returns at once; the thread renders the
snapshot and develops the image (lens, blur, exposure, noise) while the physics steps on, and MuJoCo's
rendering and OpenCV run without Python's GIL. Frames are rendered one at a time in capture order, so the
random draws of the development come in the same order as when every frame was rendered on the spot: the
images are the same, only when they are computed changes.
"""
import collections
import concurrent.futures
import queue
import threading
import time

from .scheduling import normal_scheduling

# The MjData fields mjv_updateScene reads for the geoms, lights and cameras of the scene (positions and
# orientations, as computed by the last mj_step).
SCENE_STATE_FIELDS = ("qpos", "mocap_pos", "mocap_quat", "xpos", "xquat", "xmat", "xipos", "ximat",
                      "geom_xpos", "geom_xmat", "site_xpos", "site_xmat", "cam_xpos", "cam_xmat",
                      "light_xpos", "light_xdir", "subtree_com")
FRAME_TIMEOUT_S = 30.0  # a frame not rendered within this is an error, not a wait without end [s]


class FrameRenderer:
    """Renders frames of ``camera`` (height x width) of ``model`` in its own thread. ``develop(image, job)``
    turns the raw render into the published image (run in that thread, in capture order). The OpenGL context
    is created, used and freed in that thread only."""

    def __init__(self, mujoco, model, camera, height, width, scene_option, develop):
        self._mj, self.model, self.camera = mujoco, model, camera
        self.height, self.width, self.scene_option, self.develop = height, width, scene_option, develop
        self.renderer = None
        self._spare = queue.SimpleQueue()  # snapshots whose frame is rendered, to be reused
        self._thread = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="camera",
                                                             initializer=self._started)
        self.render_s = 0.0  # thread CPU seconds spent rendering and developing [s]
        self.thread_id = None  # the rendering thread's native id, once it has started

    def _started(self):
        normal_scheduling()  # (started by a thread at a real-time priority, it would inherit it)
        self.thread_id = threading.get_native_id()

    def warm_up(self):
        """Create the OpenGL context and render once (the first frame costs the most) in the thread, now:
        before the physics starts, not at its first frame."""
        self._thread.submit(self._open_renderer)

    def _open_renderer(self):
        if self.renderer is None:
            self.renderer = self._mj.Renderer(self.model, self.height, self.width)
            self.renderer.render()

    def capture(self, data, job):
        """Snapshot ``data`` now; a Future of the developed image (``job`` is handed to ``develop``)."""
        try:
            snapshot = self._spare.get_nowait()
        except queue.Empty:
            snapshot = self._mj.MjData(self.model)
        for field in SCENE_STATE_FIELDS:
            getattr(snapshot, field)[...] = getattr(data, field)
        return self._thread.submit(self._render, snapshot, job)

    def render_now(self, data, job):
        """capture() and wait for the image."""
        return self.capture(data, job).result(timeout=FRAME_TIMEOUT_S)

    def _render(self, snapshot, job):
        start = time.thread_time()
        try:
            self._open_renderer()
            self.renderer.update_scene(snapshot, camera=self.camera, scene_option=self.scene_option)
            image = self.develop(self.renderer.render(), job)
        finally:
            self._spare.put(snapshot)
            self.render_s += time.thread_time() - start
        return image

    def close(self):
        """Finish the frames in flight, free the OpenGL context and end the thread."""
        self._thread.submit(self._close_renderer)
        self._thread.shutdown(wait=True)

    def _close_renderer(self):
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


class DeliveredFrames:
    """Frames the camera link has delivered, waiting to be published in delivery order as they are developed.

    ``add(frame, publish)`` queues a frame (a Future of its image) and ``publish(image)``, which sends it.
    ``publish_ready(wait)`` sends, in order, the frames whose image is ready; with ``wait`` all of them, waiting
    for each. The simulator calls it with ``wait`` before every /clock tick: a frame then reaches the nodes while
    ROS time still reads its delivery time, as if it had been sent at once. Meanwhile the physics steps on beside
    its rendering; without latency a frame is delivered at its capture, and used to hold the physics. Returns
    the seconds spent waiting."""

    def __init__(self):
        self._frames = collections.deque()

    def __len__(self):
        return len(self._frames)

    def add(self, frame, publish):
        self._frames.append((frame, publish))

    def publish_ready(self, wait):
        waited = 0.0
        while self._frames and (wait or self._frames[0][0].done()):
            frame, publish = self._frames.popleft()
            t0 = time.perf_counter()
            image = frame.result(timeout=FRAME_TIMEOUT_S)
            waited += time.perf_counter() - t0
            publish(image)
        return waited
