"""The POLYCHROME render engine: exports the evaluated depsgraph, renders with the
polychrome core (GIL released), reports progress, stats and errors, and fills the passes.

Polychrome must never hang or crash Blender: everything in ``render()`` is caught and
reported with ``self.report({'ERROR'}, ...)``, and ``end_result`` is always called.
"""

import dataclasses
import time
import traceback

import bpy
import numpy as np
import polychrome as pc
from polychrome.settings import SETTINGS

from . import passes, viewport
from .export import Exporter, export_scene
from .export.camera import render_size


def settings_from_scene(props, width, height):
    """``scene.polychrome`` → ``polychrome.RenderSettings``, by the settings schema: every
    setting that is a property, except those a quality preset fills that were never set
    in the panel (the schema marks the ones Blender always passes, e.g. samples); the
    size from the output resolution."""
    values = dict(width=width, height=height)
    for name, spec in SETTINGS.items():
        b = spec["blender"]
        if not b["property"]:
            continue
        if spec["from_quality"] and not b["always"] and not props.is_property_set(name):
            continue
        values[name] = getattr(props, name)
    if values.get("resume") and not values.get("checkpoint"):
        # As the CLI: beside the frame's output file.
        values["checkpoint"] = props.id_data.render.frame_path() + ".checkpoint.npz"
    if values.get("checkpoint"):
        values["checkpoint"] = bpy.path.abspath(values["checkpoint"])  # '//' is beside the .blend
    return pc.RenderSettings(**values)


def viewport_settings(props, width=1, height=1):
    """Settings of the interactive viewport render: the scene's, with the viewport's
    sample count, no time limit and no spectral passes."""
    settings = settings_from_scene(props, width, height)
    # The viewport renders on this machine (a cluster round trip per redraw is no help),
    # and never into the final render's checkpoint.
    return dataclasses.replace(
        settings, samples=int(props.viewport_samples), time_limit=0.0, spectral_output=False, scheduler="", checkpoint="", resume=False
    )


def material_preview_settings(props, width, height):
    """Settings of material / world / light preview renders (small, few samples)."""
    settings = settings_from_scene(props, width, height)
    return dataclasses.replace(
        settings,
        samples=viewport.MATERIAL_PREVIEW_SAMPLES,
        time_limit=viewport.MATERIAL_PREVIEW_TIME_LIMIT,
        spectral_output=False,
        scheduler="",
        checkpoint="",
        resume=False,
    )


def sync_viewport_scene(session, exporter, depsgraph):
    """``view_update``'s work: re-exports what changed in the evaluated depsgraph (through
    ``exporter``, which keeps the rest) and the viewport settings into ``session``; the
    render restarts (in ``sync``) only if the exported scene or the settings differ from
    what is rendering. Returns the export warnings."""
    exporter.update(depsgraph)
    scene, warnings = exporter.export(depsgraph, camera=pc.Camera(name="Viewport"))
    desc, buffers = scene.description()
    session.set_scene(desc, buffers)
    session.set_settings(viewport_settings(depsgraph.scene.polychrome))
    session.sync()
    return warnings


def sync_viewport_view(session, region_data, region_width, region_height, pixel_size):
    """``view_draw``'s work before drawing: the view's camera and size into ``session``
    (restarting the render if they changed); returns the render size."""
    width, height = viewport.viewport_size(region_width, region_height, pixel_size)
    camera = viewport.view_camera(region_data.view_matrix, region_data.window_matrix, width, height)
    session.set_view(camera, width, height)
    session.sync()
    return width, height


def border_rect(scene, width, height):
    """Blender's render border in pixels (x0, y0, x1, y1), y from the bottom; the whole
    frame when the border is off. Only the border is rendered (the ``region`` setting)."""
    r = scene.render
    if not r.use_border:
        return 0, 0, width, height
    # Blender truncates the border's corners to pixels (its render result is that size).
    x0 = min(max(int(r.border_min_x * width), 0), width)
    x1 = min(max(int(r.border_max_x * width), x0), width)
    y0 = min(max(int(r.border_min_y * height), 0), height)
    y1 = min(max(int(r.border_max_y * height), y0), height)
    if x1 - x0 < 1 or y1 - y0 < 1:
        return 0, 0, width, height
    return x0, y0, x1, y1


class PolychromeRenderEngine(bpy.types.RenderEngine):
    bl_idname = "POLYCHROME"
    bl_label = "Polychrome"
    bl_use_preview = True  # material, world and light previews render through render()
    bl_use_eevee_viewport = True  # Material Preview shading uses EEVEE (as Cycles); Rendered uses view_draw
    bl_use_shading_nodes_custom = False  # keep the standard Shader Editor
    bl_use_postprocess = True

    # For tests and scripts: the last render's outcome (class attributes, so they
    # survive the engine instance).
    last_error = None
    last_warnings = []
    last_stats = None
    # Optional callable(done, total) -> bool that cancels like Esc when it returns True.
    test_break_hook = None
    # Final renders show intermediate images: None = only when Blender has a UI (not in
    # background mode), True/False to force; PROGRESSIVE_INTERVAL seconds between them.
    progressive_final = None
    PROGRESSIVE_INTERVAL = 1.0
    intermediate_updates = 0  # count of intermediate images shown (for tests)

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.session = None  # ViewportSession of an interactive viewport render
        self.exporter = None  # its Exporter, which keeps what did not change between updates
        self._texture = None
        self._texture_serial = None
        self._reported = set()

    def __del__(self):
        # Blender frees the engine when the viewport stops rendering or closes: never
        # leave a render thread behind (Blender would otherwise wait on exit).
        try:
            session = getattr(self, "session", None)
            if session is not None:
                self.session = None
                session.free(timeout=2.0)
        except Exception:  # noqa: BLE001 - the RNA struct may already be gone
            pass

    def _report_once(self, level, msg):
        reported = getattr(self, "_reported", None)
        if reported is None:
            reported = self._reported = set()
        if msg not in reported:
            reported.add(msg)
            self._report(level, msg)

    def view_update(self, context, depsgraph):
        """Called on every depsgraph change while the viewport shows Rendered shading:
        re-export what changed and restart the render when the scene or settings changed."""
        try:
            if getattr(self, "session", None) is None:
                self.session = viewport.ViewportSession()
            if getattr(self, "exporter", None) is None:
                self.exporter = Exporter()
            for w in sync_viewport_scene(self.session, self.exporter, depsgraph):
                self._report_once("WARNING", w)
        except BaseException as e:  # noqa: BLE001 - nothing may escape into Blender
            self._report_once("ERROR", str(e) or type(e).__name__)
            if not isinstance(e, (ValueError, TypeError)):
                traceback.print_exc()
        self.tag_redraw()

    def view_draw(self, context, depsgraph):
        """Draws the newest preview; restarts the render when the view changed, and asks
        for another redraw while it refines."""
        session = getattr(self, "session", None)
        if session is None:
            return
        try:
            props = depsgraph.scene.polychrome
            region = context.region
            # settings edits do not always reach view_update (Python property sets); the
            # redraw that follows them does
            session.set_settings(viewport_settings(props))
            sync_viewport_view(session, context.region_data, region.width, region.height, props.viewport_pixel_size)
            session.poll()
            if session.error:
                self._report_once("ERROR", session.error)
            if session.latest is not None:
                self._draw_preview(depsgraph.scene, session.latest, region.width, region.height)
            if session.refining:
                self.update_stats("", f"Polychrome | viewport | sample {session.samples}/{props.viewport_samples}")
                self.tag_redraw()
            elif session.latest is not None:
                self.update_stats("", f"Polychrome | viewport | {session.samples} samples")
        except BaseException as e:  # noqa: BLE001
            self._report_once("ERROR", str(e) or type(e).__name__)
            if not isinstance(e, (ValueError, TypeError)):
                traceback.print_exc()

    def _draw_preview(self, scene, preview, region_width, region_height):
        import gpu
        from gpu_extras.presets import draw_texture_2d

        if getattr(self, "_texture_serial", None) != preview.serial or getattr(self, "_texture", None) is None:
            h, w = preview.rgba.shape[:2]
            rgba = np.nan_to_num(np.ascontiguousarray(preview.rgba[::-1], np.float32), nan=0.0, posinf=0.0, neginf=0.0)
            buf = gpu.types.Buffer("FLOAT", rgba.size, rgba.ravel())
            self._texture = gpu.types.GPUTexture((w, h), format="RGBA16F", data=buf)
            self._texture_serial = preview.serial
        gpu.state.blend_set("ALPHA_PREMULT")
        self.bind_display_space_shader(scene)
        draw_texture_2d(self._texture, (0, 0), region_width, region_height)
        self.unbind_display_space_shader()
        gpu.state.blend_set("NONE")

    def _progressive_final(self):
        mode = type(self).progressive_final
        return (not bpy.app.background) if mode is None else bool(mode)

    def _run_render(self, scene, settings, progress, depsgraph, width, height):
        """The render itself; with a UI (``progressive_final``), on a background job whose
        previews are shown in the Image Editor about every ``PROGRESSIVE_INTERVAL`` s. With
        ``scene.polychrome.scheduler`` set, on that Dask cluster (docs/distributed.md)."""
        if self.is_preview or not self._progressive_final() or settings.scheduler:
            return pc.render(scene, settings, progress=progress)
        job = pc.RenderJob(scene, settings).start()
        shown, last_shown = 0, time.perf_counter()
        try:
            while not job.wait(0.05):
                if progress(*job.progress()) is False:
                    job.cancel()
                now = time.perf_counter()
                serial = job.preview_serial()
                if serial not in (0, shown) and (shown == 0 or now - last_shown >= self.PROGRESSIVE_INTERVAL):
                    p = job.preview()
                    if p is not None and not p.last:
                        self._show_intermediate(depsgraph, p.rgba, width, height)
                        shown, last_shown = p.serial, now
        except BaseException:
            job.cancel()
            job.wait()
            raise
        return job.result()

    def _show_intermediate(self, depsgraph, rgba, width, height):
        """Shows a preview (Combined only) in the render result; the final image replaces it."""
        x0, y0, x1, y1 = border_rect(depsgraph.scene, width, height)
        rgba = np.nan_to_num(np.asarray(rgba, np.float32)[::-1], nan=0.0, posinf=0.0, neginf=0.0)[y0:y1, x0:x1]
        layer = depsgraph.view_layer.name if depsgraph.view_layer else ""
        result = self.begin_result(0, 0, x1 - x0, y1 - y0, layer=layer)
        try:
            combined = result.layers[0].passes.get("Combined") if result is not None else None
            if combined is not None and combined.channels == 4:
                combined.rect.foreach_set(np.ascontiguousarray(rgba).ravel())
                self.update_result(result)
                type(self).intermediate_updates += 1
        finally:
            if result is not None:
                self.end_result(result)

    def update_render_passes(self, scene=None, renderlayer=None):
        passes.register_passes(self, scene, renderlayer)

    def _report(self, level, msg):
        print(f"Polychrome {level}: {msg}", flush=True)
        try:
            self.report({level}, msg)
        except Exception:  # noqa: BLE001 - reporting must not raise
            pass

    def render(self, depsgraph):
        cls = type(self)
        cls.last_error, cls.last_warnings, cls.last_stats = None, [], None
        scene = depsgraph.scene
        width, height = render_size(scene)
        result = None
        arrays = None
        try:
            arrays = self._render(depsgraph, width, height)
        except BaseException as e:  # noqa: BLE001 - nothing may escape into Blender
            msg = str(e) or type(e).__name__
            if not isinstance(e, (ValueError, TypeError, ImportError, KeyboardInterrupt)):
                msg = f"{type(e).__name__}: {msg}"
                traceback.print_exc()
            cls.last_error = msg
            self._report("ERROR", msg)
        finally:
            try:
                layer = depsgraph.view_layer.name if depsgraph.view_layer else ""
                if arrays is None:
                    arrays = passes.pass_arrays(None, width, height)
                x0, y0, x1, y1 = border_rect(scene, width, height)
                if (x0, y0, x1, y1) != (0, 0, width, height):
                    arrays = {k: v[y0:y1, x0:x1] for k, v in arrays.items()}  # rows already bottom-up
                # with a border, Blender's result covers only the border, from its corner
                result = self.begin_result(0, 0, x1 - x0, y1 - y0, layer=layer)
                passes.fill_result(result, arrays)
            except Exception as e:  # noqa: BLE001
                cls.last_error = cls.last_error or f"writing the render result failed: {e}"
                traceback.print_exc()
            finally:
                if result is not None:
                    self.end_result(result)

    def _render(self, depsgraph, width, height):
        cls = type(self)
        props = depsgraph.scene.polychrome
        if self.is_preview:
            settings = material_preview_settings(props, width, height)
        else:
            settings = settings_from_scene(props, width, height)
            x0, y0, x1, y1 = border_rect(depsgraph.scene, width, height)
            if (x0, y0, x1, y1) != (0, 0, width, height):
                # Only the border is rendered (rows counted from the top in the core).
                settings.region = (x0, height - y1, x1, height - y0)
        self.update_stats("", "Polychrome | exporting scene")
        t0 = time.perf_counter()
        scene, warnings = export_scene(depsgraph, frame_set=None if self.is_preview else self.frame_set)
        cls.last_warnings = list(warnings)
        if not self.is_preview:  # the preview scene's checker floor etc. would warn every time
            for w in warnings:
                self._report("WARNING", w)
        export_time = time.perf_counter() - t0
        if self.test_break():
            return None
        method = props.method.replace("_", " ").title()
        if props.direction != "BACKWARD":
            method += f" {props.direction.title()}"
        start = time.perf_counter()

        def progress(done, total):
            try:
                if total:
                    self.update_progress(min(1.0, done / total))
                spp = settings.samples * done / total if total else 0.0  # totals differ per method
                self.update_stats(
                    "",
                    f"Polychrome | {method} | {settings.wavelength_count or props.quality.lower()} wavelengths | "
                    f"sample {spp:.1f}/{settings.samples} | {time.perf_counter() - start:.1f} s",
                )
                hook = cls.test_break_hook
                if hook is not None and hook(done, total):
                    return False
                return not self.test_break()
            except Exception:  # noqa: BLE001 - a failing callback cancels rather than crashes
                traceback.print_exc()
                return False

        out = self._run_render(scene, settings, progress, depsgraph, width, height)
        stats = dict(out.stats)
        stats["export_seconds"] = export_time
        for w in stats.get("warnings", []):  # what the core left out (e.g. FORWARD and moving emitters)
            cls.last_warnings.append(w)
            self._report("WARNING", w)
        cls.last_stats = stats
        self.update_progress(1.0)
        self.update_stats(
            "",
            f"Polychrome | {method} | {stats.get('wavelengths', settings.wavelength_count)} wavelengths | "
            f"done in {time.perf_counter() - start:.1f} s",
        )
        return passes.pass_arrays(out, width, height)


def register():
    bpy.utils.register_class(PolychromeRenderEngine)


def unregister():
    viewport.free_all()
    bpy.utils.unregister_class(PolychromeRenderEngine)
