"""Motion history (temporal reprojection): what the last frame saw, and the buffer of where
each primitive was then, which the G-buffer's motion vectors read.

inputs:  scene, camera (this frame's, and the last frame's kept here)
outputs: prev_positions (SSBO at the `prev_positions` binding, lift_gl/bindings.py: row i of
         triangle corners and spheres where the previous frame saw them, then the instance
         records' previous transforms; lift_gl/temporal.py previous_positions), and the
         G-buffer's motion-vector uniforms

Not a dispatch of its own: the G-buffer pass reads the buffer (shaders/passes/motion_vectors.glsl).
"""
from __future__ import annotations

from ..bindings import STORAGE_BUFFERS
from ..temporal import motion_uniforms, objects_moved, previous_positions, same_camera

PREV_POSITIONS_BINDING = STORAGE_BUFFERS["prev_positions"]


class MotionHistory:
    def __init__(self, ctx):
        self.ctx = ctx
        self.buffer = None    # the prev_positions SSBO
        self.still = False    # whether it holds this scene's positions as they are
        self.camera = self.scene = None   # what the last frame saw (None: nothing to reproject from)

    def forget(self) -> None:
        """Accumulation restarted: the next frame has nothing to reproject from."""
        self.camera = self.scene = None

    def scene_changed(self) -> None:
        """The scene was edited: the buffer is rewritten on the next frame."""
        self.still = False

    def remember(self, scene) -> None:
        """What this frame saw, for the next one."""
        self.camera, self.scene = scene.camera, scene

    def bind(self, packed, scene, size, frame: bool = True) -> tuple[bool, dict]:
        """Whether something moved since the last frame, and the G-buffer's motion-vector
        uniforms; the buffer bound. frame=False (the guides' G-buffer run, not a frame): no
        motion, and the history is left alone."""
        camera = scene.camera
        before_camera = self.camera if frame and self.camera is not None else camera
        before_scene = self.scene if frame and self.scene is not None else scene
        objects = objects_moved(before_scene, scene)
        if objects or not self.still:
            rows = previous_positions(packed, before_scene if objects else None, scene)
            if self.buffer is None or self.buffer.size != rows.nbytes:
                if self.buffer is not None:
                    self.buffer.release()
                self.buffer = self.ctx.buffer(reserve=max(rows.nbytes, 16))
            self.buffer.write(rows.tobytes())
            self.still = not objects
        self.buffer.bind_to_storage_buffer(PREV_POSITIONS_BINDING)
        moved = objects or not same_camera(before_camera, camera)
        uniforms = motion_uniforms(packed.to_gpu_camera(before_camera), packed.to_gpu_camera(camera), size,
                                   packed.bounds)
        uniforms["u_prev_instance_rows"] = 3 * packed.num_triangles + packed.num_spheres
        return moved, uniforms

    def release(self) -> None:
        if self.buffer is not None:
            self.buffer.release()
            self.buffer = None
