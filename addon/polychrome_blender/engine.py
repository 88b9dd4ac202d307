"""The POLYCHROME render engine: exports the evaluated depsgraph, renders with the
polychrome core (GIL released), reports progress, stats and errors, and fills the passes.

Polychrome must never hang or crash Blender: everything in ``render()`` is caught and
reported with ``self.report({'ERROR'}, ...)``, and ``end_result`` is always called.
"""

import dataclasses
import time
import traceback

import bpy

from . import passes


def settings_from_scene(pc, props, width, height):
    """``scene.polychrome`` → ``polychrome.RenderSettings`` (same names)."""
    fields = {f.name for f in dataclasses.fields(pc.RenderSettings)}
    values = dict(width=width, height=height, samples=props.samples, method=props.method,
                  wavelength_count=props.wavelength_count, max_bounces=props.max_bounces, seed=props.seed,
                  threads=props.threads, time_limit=props.time_limit, uplift=props.uplift)
    if "spectral_output" in fields:
        values["spectral_output"] = bool(getattr(props, "spectral_output", False))
    if "dispersion_splitting" in fields:
        values["dispersion_splitting"] = bool(props.dispersion_splitting)
    if "direction" in fields:
        values["direction"] = props.direction
    elif props.direction != "BACKWARD":
        raise ValueError(f"setting 'direction': '{props.direction}' is not supported by this polychrome version (only BACKWARD)")
    return pc.RenderSettings(**values)


def border_rect(scene, width, height):
    """Blender's render border in pixels (x0, y0, x1, y1), y from the bottom; the whole
    frame when the border is off. Polychrome renders the whole frame and crops."""
    r = scene.render
    if not r.use_border:
        return 0, 0, width, height
    x0 = min(max(int(round(r.border_min_x * width)), 0), width)
    x1 = min(max(int(round(r.border_max_x * width)), x0), width)
    y0 = min(max(int(round(r.border_min_y * height)), 0), height)
    y1 = min(max(int(round(r.border_max_y * height)), y0), height)
    if x1 - x0 < 1 or y1 - y0 < 1:
        return 0, 0, width, height
    return x0, y0, x1, y1


class PolychromeRenderEngine(bpy.types.RenderEngine):
    bl_idname = "POLYCHROME"
    bl_label = "Polychrome"
    bl_use_preview = False
    bl_use_shading_nodes_custom = False  # keep the standard Shader Editor
    bl_use_postprocess = True

    # For tests and scripts: the last render's outcome (class attributes, so they
    # survive the engine instance).
    last_error = None
    last_warnings = []
    last_stats = None
    # Optional callable(done, total) -> bool that cancels like Esc when it returns True.
    test_break_hook = None

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
        from .export.camera import render_size

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
        import polychrome as pc

        from .export import export_scene

        cls = type(self)
        props = depsgraph.scene.polychrome
        settings = settings_from_scene(pc, props, width, height)
        self.update_stats("", "Polychrome | exporting scene")
        t0 = time.perf_counter()
        scene, warnings = export_scene(pc, depsgraph)
        cls.last_warnings = list(warnings)
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
                self.update_stats("", f"Polychrome | {method} | {settings.wavelength_count} wavelengths | "
                                      f"sample {spp:.1f}/{settings.samples} | {time.perf_counter() - start:.1f} s")
                hook = cls.test_break_hook
                if hook is not None and hook(done, total):
                    return False
                return not self.test_break()
            except Exception:  # noqa: BLE001 - a failing callback cancels rather than crashes
                traceback.print_exc()
                return False

        out = pc.render(scene, settings, progress=progress)
        stats = dict(out.stats)
        stats["export_seconds"] = export_time
        cls.last_stats = stats
        self.update_progress(1.0)
        self.update_stats("", f"Polychrome | {method} | {settings.wavelength_count} wavelengths | "
                              f"done in {time.perf_counter() - start:.1f} s")
        return passes.pass_arrays(out, width, height)


def register():
    bpy.utils.register_class(PolychromeRenderEngine)


def unregister():
    bpy.utils.unregister_class(PolychromeRenderEngine)
