"""The stepping loop of simulate.run, replay.replay and sweep's mode pass: step (or pose) a model,
copy a frame out every `every` steps into a capture.FrameBuffer, decide its chunks of frames, hand
each to the caller and to a record.Recorder, collect the contacts between frames, and time each part.

    loop = FrameLoop(model, recorder=recorder, title="pile", on_chunk=keep)
    loop.run(data, steps, step, every=8)        # step(k): mj_step, or a pose and mj_forward
    loop.seconds, loop.analysis_seconds, loop.record_seconds, loop.events()
"""

import time

from ..mujoco.between import Events
from . import capture
from .errors import STOPS


class FrameLoop:
    """Frames of one model's steps, decided a chunk at a time (capture.FrameBuffer) and recorded.

    names : the model's capture.ModelNames (built when None)
    recorder : optional record.Recorder, begun here with the model's geometry called `title`, sent
        every chunk and the contacts between frames (closing it is the caller's)
    on_chunk : optional callable(capture.Chunk), each decided chunk in frame order, before it is recorded
    depth, between, background : as capture.FrameBuffer's
    After `run`: seconds, the wall time of stepping and copying frames out; analysis_seconds, of
    ellipsim's verdicts, on_chunk and waiting for the background check; record_seconds, of the recorder.
    """

    def __init__(
        self, model, *, names=None, recorder=None, title="", on_chunk=None, depth=False, between=False, background=False
    ):
        self.names = capture.ModelNames.of(model) if names is None else names
        record = recorder is not None
        self.buffer = capture.FrameBuffer(model, record=record, depth=depth, between=between, background=background)
        self.recorder, self.on_chunk = recorder, on_chunk
        self.seconds = self.analysis_seconds = self.record_seconds = 0.0
        self._events = []  # between.Events, in frame order
        self._writing = False
        self.steps_done = 0
        if recorder is not None:
            recorder.begin(capture.geometry(model, title, self.names))
            recorder.between_checked = between  # the legend says whether they were looked for

    def run(self, data, steps, step, *, every=1, progress=None):
        """step(k) for k = 0 .. steps - 1, a frame of `data` (at data.time) after every k % every == 0,
        then the last chunk and the background check; the buffer is closed, also on an error.
        progress : optional callable(k + 1, steps).
        On Ctrl-C or SIGTERM (errors.STOPS) with a recorder that keeps partial recordings
        (record.Recorder keep_partial), the frames still in the buffer are decided and recorded
        first, and progress is told the steps done, before the exception goes on; `steps_done` is
        their number."""
        buffer = self.buffer
        t0 = time.perf_counter()
        self.steps_done = 0
        try:
            for k in range(steps):
                step(k)
                full = k % every == 0 and buffer.add(data, data.time)
                self.steps_done = k + 1
                if full:
                    self._flush()
                if progress is not None:
                    progress(k + 1, steps)
            self._flush()
            t1 = time.perf_counter()
            found = buffer.collect(wait=True)
            self.analysis_seconds += time.perf_counter() - t1
            self._keep(found)
        except STOPS:
            if getattr(self.recorder, "keep_partial", False) and not self._writing:
                self._flush()  # a second Ctrl-C here ends it: the recorder keeps what it has
            if progress is not None:
                progress(self.steps_done, steps)
            raise
        finally:
            buffer.close()
        self.seconds = time.perf_counter() - t0 - self.analysis_seconds - self.record_seconds

    def events(self):
        """The contacts between frames found (between.Events, frame order), or None when not looked for."""
        return Events.concatenate(self._events) if self.buffer.between is not None else None

    def _flush(self):
        t0 = time.perf_counter()
        chunk = self.buffer.flush()
        if chunk is not None and self.on_chunk is not None:
            self.on_chunk(chunk)
        t1 = time.perf_counter()
        self.analysis_seconds += t1 - t0
        if chunk is None:
            return
        if self.recorder is not None:
            self._writing = True  # stopped while writing a chunk: no second try at it
            self.recorder.write(chunk.frames)
            self._writing = False
            self.record_seconds += time.perf_counter() - t1
        self._keep(([chunk.events] if chunk.events is not None else []) + self.buffer.collect())

    def _keep(self, found):
        """Keep and record contacts between frames (between.Events, inline or from the background)."""
        self._events.extend(found)
        if self.recorder is not None:
            t0 = time.perf_counter()
            for events in found:
                capture.record_events(self.recorder, events, self.buffer.ellipsoid_ids, self.names)
            self.record_seconds += time.perf_counter() - t0
