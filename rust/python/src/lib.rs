//! `polychrome._core`: the bindings. They turn numpy buffers and JSON descriptions into
//! core types, release the GIL while rendering, poll progress and cancellation from the
//! calling thread, and map every error — and, as a last resort, every panic — to a
//! Python exception with a readable message.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArrayDyn};
use polychrome_core::color::uplift::Uplift;
use polychrome_core::color::{Observer, RgbSpace};
use polychrome_core::film::FilmBuffer;
use polychrome_core::geometry::curves::{self, CurveOptions, Tessellation};
use polychrome_core::material::catalogue;
use polychrome_core::material::dispersion::{self, IorDesc};
use polychrome_core::render::adaptive::AdaptiveState;
use polychrome_core::render::settings::schema_json;
use polychrome_core::render::tasks::MergeState;
use polychrome_core::render::{
    compile, render as core_render, Driver, Merge, RenderControl, RenderOutput, RenderSettings, ResolvedSettings,
    Timing,
};
use polychrome_core::scene::{AsBufferView, Buffer, BufferView, Scene, SceneDesc};
use polychrome_core::spectrum::named::{RgbToSpectrum, SpectrumRole};
use polychrome_core::spectrum::SpectrumDesc;
use polychrome_core::Error;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn to_py_err(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".into()
    }
}

/// Runs core code, turning a panic into a RuntimeError instead of aborting Python.
fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, Error>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r.map_err(to_py_err),
        Err(p) => {
            Err(PyRuntimeError::new_err(format!("internal error in {what} (please report): {}", panic_message(p))))
        }
    }
}

fn parse<T: serde::de::DeserializeOwned>(json: &str, what: &str) -> PyResult<T> {
    serde_json::from_str(json).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// One numpy buffer of a call, borrowed read-only (numpy's borrow flag: no Rust code
/// writes it meanwhile).
enum Lent<'py> {
    F32(PyReadonlyArrayDyn<'py, f32>),
    U32(PyReadonlyArrayDyn<'py, u32>),
    U8(PyReadonlyArrayDyn<'py, u8>),
}

impl Lent<'_> {
    /// The array in place when it is contiguous (the scene's buffers always are).
    fn view(&self) -> Option<BufferView<'_>> {
        match self {
            Lent::F32(a) => a.as_slice().ok().map(BufferView::F32),
            Lent::U32(a) => a.as_slice().ok().map(BufferView::U32),
            Lent::U8(a) => a.as_slice().ok().map(BufferView::U8),
        }
    }

    fn to_owned_buffer(&self) -> Buffer {
        match self {
            Lent::F32(a) => Buffer::F32(a.as_array().iter().copied().collect()),
            Lent::U32(a) => Buffer::U32(a.as_array().iter().copied().collect()),
            Lent::U8(a) => Buffer::U8(a.as_array().iter().copied().collect()),
        }
    }
}

fn lend_buffers<'py>(buffers: &[Bound<'py, PyAny>]) -> PyResult<Vec<Lent<'py>>> {
    buffers
        .iter()
        .enumerate()
        .map(|(i, b)| {
            if let Ok(a) = b.extract::<PyReadonlyArrayDyn<f32>>() {
                Ok(Lent::F32(a))
            } else if let Ok(a) = b.extract::<PyReadonlyArrayDyn<u32>>() {
                Ok(Lent::U32(a))
            } else if let Ok(a) = b.extract::<PyReadonlyArrayDyn<u8>>() {
                Ok(Lent::U8(a))
            } else {
                Err(PyTypeError::new_err(format!("buffer {i}: expected a float32, uint32 or uint8 numpy array")))
            }
        })
        .collect()
}

/// Copies of the buffers, for a render that outlives the call (`RenderJob`).
fn convert_buffers(buffers: Vec<Bound<'_, PyAny>>) -> PyResult<Vec<Buffer>> {
    Ok(lend_buffers(&buffers)?.iter().map(Lent::to_owned_buffer).collect())
}

/// Copies of the strided buffers among `lent` (None where one is read in place); with
/// [`views`] the buffers of a call that reads them before it returns, so a large mesh's
/// arrays are not copied (they are 28 bytes per triangle on a grid with normals and uvs).
/// The caller's Python code could still write an array while the GIL is released; the
/// build then reads some old and some new values, as numpy's own threads would.
fn strided_copies(lent: &[Lent<'_>]) -> Vec<Option<Buffer>> {
    lent.iter().map(|a| if a.view().is_some() { None } else { Some(a.to_owned_buffer()) }).collect()
}

fn views<'a>(lent: &'a [Lent<'_>], copies: &'a [Option<Buffer>]) -> Vec<BufferView<'a>> {
    lent.iter()
        .zip(copies)
        .map(|(a, c)| match c {
            Some(b) => b.view(),
            None => a.view().expect("contiguous: no copy was made"),
        })
        .collect()
}

/// render(scene_json, buffers, settings_json, progress=None) -> dict
///
/// `progress(done, total)` is called from this thread about 20 times a second; return
/// False to cancel. Ctrl-C cancels too. The dict holds `rgba` (H, W, 4), `depth`
/// (H, W), `normal` (H, W, 3), `albedo` (H, W, 3), `spectral` (H, W, N) or None,
/// `wavelengths` (N,) and `stats` (JSON text).
#[pyfunction]
#[pyo3(signature = (scene_json, buffers, settings_json, progress=None))]
fn render<'py>(
    py: Python<'py>,
    scene_json: &str,
    buffers: Vec<Bound<'py, PyAny>>,
    settings_json: &str,
    progress: Option<PyObject>,
) -> PyResult<Bound<'py, PyDict>> {
    let desc: SceneDesc = parse(scene_json, "scene description")?;
    // Null or absent settings are left to `quality`; they are resolved on the worker.
    let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
    let lent = lend_buffers(&buffers)?;
    let copies = strided_copies(&lent);
    let buffers = views(&lent, &copies);
    let control = RenderControl::new();
    let mut callback_error: Option<PyErr> = None;
    let result = py.allow_threads(|| {
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| guarded("render", || resolve_and_render(&desc, &buffers, &settings, &control)));
            while !worker.is_finished() {
                std::thread::sleep(Duration::from_millis(50));
                Python::with_gil(|py| {
                    if let Err(e) = py.check_signals() {
                        callback_error.get_or_insert(e);
                        control.cancel();
                        return;
                    }
                    if let Some(cb) = &progress {
                        let (done, total) = control.progress();
                        match cb.call1(py, (done, total)) {
                            Ok(r) if r.bind(py).is(&*pyo3::types::PyBool::new(py, false)) => control.cancel(),
                            Ok(_) => {}
                            Err(e) => {
                                callback_error.get_or_insert(e);
                                control.cancel();
                            }
                        }
                    }
                });
            }
            worker
                .join()
                .unwrap_or_else(|p| Err(PyRuntimeError::new_err(format!("render thread died: {}", panic_message(p)))))
        })
    });
    if let Some(e) = callback_error {
        return Err(e);
    }
    output_dict(py, result?)
}

type JobOutcome = PyResult<RenderOutput>;

/// The settings resolved for the scene (quality preset, AUTO's grid), then the render.
fn resolve_and_render<B: AsBufferView + Sync>(
    desc: &SceneDesc,
    buffers: &[B],
    settings: &RenderSettings,
    control: &RenderControl,
) -> Result<RenderOutput, Error> {
    control.plan(settings.planned_pixel_samples()); // AUTO's grid fitting may take a moment
    core_render(desc, buffers, &settings.resolve(Some(desc))?, control)
}

/// RenderJob(scene_json, buffers, settings_json, previews=True)
///
/// A render on a background thread (no GIL held while it runs), for progressive
/// display: `start()`, then poll `progress()` / `preview()` from any thread, `cancel()`,
/// `wait(timeout)`, and `result()` (the dict of `render`; taken once). With `previews`
/// the core publishes a snapshot of the image after the first pass, then at most every
/// 100 ms, and the final image last. Dropping a running job cancels it.
#[pyclass(module = "polychrome._core", frozen)]
struct RenderJob {
    control: Arc<RenderControl>,
    input: Mutex<Option<(SceneDesc, Vec<Buffer>, RenderSettings)>>,
    handle: Mutex<Option<std::thread::JoinHandle<JobOutcome>>>,
    outcome: Mutex<Option<JobOutcome>>,
    started: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl RenderJob {
    /// Joins a finished worker into `outcome`; false while it runs.
    fn collect(&self) -> bool {
        let mut handle = lock(&self.handle);
        if let Some(h) = handle.as_ref() {
            if !h.is_finished() {
                return false;
            }
            let h = handle.take().expect("checked above");
            let outcome = h
                .join()
                .unwrap_or_else(|p| Err(PyRuntimeError::new_err(format!("render thread died: {}", panic_message(p)))));
            *lock(&self.outcome) = Some(outcome);
        }
        // Not started (callers check) or joined: the outcome is known (or already taken).
        true
    }
}

#[pymethods]
impl RenderJob {
    #[new]
    #[pyo3(signature = (scene_json, buffers, settings_json, previews=true))]
    fn new(scene_json: &str, buffers: Vec<Bound<'_, PyAny>>, settings_json: &str, previews: bool) -> PyResult<Self> {
        let desc: SceneDesc = parse(scene_json, "scene description")?;
        // As `render`: resolved (quality, AUTO) on the render thread.
        let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
        let buffers = convert_buffers(buffers)?;
        let control = if previews { RenderControl::with_previews() } else { RenderControl::new() };
        Ok(Self {
            control: Arc::new(control),
            input: Mutex::new(Some((desc, buffers, settings))),
            handle: Mutex::new(None),
            outcome: Mutex::new(None),
            started: AtomicBool::new(false),
        })
    }

    /// Starts rendering on a new thread (once).
    fn start(&self) -> PyResult<()> {
        let Some((desc, buffers, settings)) = lock(&self.input).take() else {
            return Err(PyRuntimeError::new_err("RenderJob.start(): the job was already started"));
        };
        let control = self.control.clone();
        let handle = std::thread::Builder::new()
            .name("polychrome-render".into())
            .spawn(move || guarded("render", || resolve_and_render(&desc, &buffers, &settings, &control)))
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the render thread: {e}")))?;
        *lock(&self.handle) = Some(handle);
        self.started.store(true, std::sync::atomic::Ordering::Release);
        Ok(())
    }

    /// (pixel samples done, pixel samples planned).
    fn progress(&self) -> (u64, u64) {
        self.control.progress()
    }

    /// Asks the render to stop; it ends after the pass in flight is dropped.
    fn cancel(&self) {
        self.control.cancel();
    }

    /// True when the job was started and its thread has ended.
    fn done(&self) -> bool {
        self.started.load(std::sync::atomic::Ordering::Acquire) && self.collect()
    }

    /// Serial number of the newest preview (0: none yet), without copying it.
    fn preview_serial(&self) -> u64 {
        self.control.latest_preview().map_or(0, |p| p.serial)
    }

    /// The newest preview as (rgba (H, W, 4) float32 with row 0 at the top, samples per
    /// pixel, serial, last), or None before the first pass ends.
    fn preview<'py>(&self, py: Python<'py>) -> PyResult<Option<(Bound<'py, PyAny>, u32, u64, bool)>> {
        let Some(p) = self.control.latest_preview() else { return Ok(None) };
        let rgba = PyArray1::from_slice(py, &p.rgba).reshape([p.height as usize, p.width as usize, 4])?;
        Ok(Some((rgba.into_any(), p.samples_per_pixel, p.serial, p.last)))
    }

    /// Waits (GIL released) until the job ends or `timeout` seconds pass; returns whether
    /// it ended. Ctrl-C cancels the job and raises KeyboardInterrupt.
    #[pyo3(signature = (timeout=None))]
    fn wait(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<bool> {
        if !self.started.load(std::sync::atomic::Ordering::Acquire) {
            return Err(PyRuntimeError::new_err("RenderJob.wait(): the job was not started"));
        }
        let deadline = timeout.map(|t| std::time::Instant::now() + Duration::from_secs_f64(t.clamp(0.0, 1e9)));
        loop {
            let finished = py.allow_threads(|| {
                let step = std::time::Instant::now() + Duration::from_millis(50);
                loop {
                    if self.collect() {
                        return true;
                    }
                    let now = std::time::Instant::now();
                    if now >= step || deadline.is_some_and(|d| now >= d) {
                        return false;
                    }
                    std::thread::sleep(Duration::from_millis(1));
                }
            });
            if finished {
                return Ok(true);
            }
            if let Err(e) = py.check_signals() {
                self.control.cancel();
                return Err(e);
            }
            if deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                return Ok(false);
            }
        }
    }

    /// Waits for the end and returns the render's dict (as `render`); raises the render's
    /// error. The result can be taken once.
    fn result<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.wait(py, None)?;
        match lock(&self.outcome).take() {
            Some(Ok(out)) => output_dict(py, out),
            Some(Err(e)) => Err(e),
            None => Err(PyRuntimeError::new_err("RenderJob.result(): the result was already taken")),
        }
    }
}

impl Drop for RenderJob {
    fn drop(&mut self) {
        // A running render must not outlive its owner doing useless work.
        self.control.cancel();
    }
}

/// PassRenderer(scene_json, buffers, settings_json)
///
/// A scene compiled once for rendering in tasks (`polychrome.distributed`). A worker
/// calls `render_passes(start, end, active)` for the sums of a range of sample passes;
/// the client adds tasks' sums with `add(sums, first_half)` and `end_group(passes)` in
/// the groups of `groups()` (adaptive sampling: `active()` between groups) and takes the
/// image with `output(...)`, the dict of `render`. Same seed and settings: the same
/// image as `render`, to float rounding.
#[pyclass(module = "polychrome._core", frozen)]
struct PassRenderer {
    scene: Scene,
    settings: ResolvedSettings,
    pool: rayon::ThreadPool,
    build_seconds: f64,
    merge: Mutex<Option<Merge>>,
    /// Shared by every `render_passes` of this object: `cancel()` ends them all.
    control: RenderControl,
}

impl PassRenderer {
    fn driver(&self) -> PyResult<Driver<'_>> {
        Driver::new(&self.scene, &self.settings).map_err(to_py_err)
    }

    /// `f` on the merge state, a panic in it (core code) turned into a RuntimeError as by
    /// [`guarded`] (not pyo3's PanicException, a BaseException `except Exception` misses).
    fn with_merge<T>(&self, f: impl FnOnce(&Driver, &mut Merge) -> PyResult<T>) -> PyResult<T> {
        let driver = self.driver()?;
        let mut slot = lock(&self.merge);
        catch_unwind(AssertUnwindSafe(|| {
            let merge = slot.get_or_insert_with(|| Merge::new(&driver));
            f(&driver, merge)
        }))
        .unwrap_or_else(|p| {
            Err(PyRuntimeError::new_err(format!(
                "internal error in PassRenderer (please report): {}",
                panic_message(p)
            )))
        })
    }

    fn pixels(&self) -> usize {
        self.settings.width as usize * self.settings.height as usize
    }

    /// A rectangle (x0, y0, x1, y1) non-empty and inside the image.
    fn check_rect(&self, r: [u32; 4]) -> PyResult<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        if !(r[0] < r[2] && r[1] < r[3] && r[2] <= w && r[3] <= h) {
            return Err(PyValueError::new_err(format!(
                "rect {r:?}: not a non-empty rectangle inside the {w}×{h} image"
            )));
        }
        Ok(())
    }
}

/// The sums of a film buffer as numpy arrays (pixels row-major).
fn sums_dict<'py>(py: Python<'py>, b: FilmBuffer) -> PyResult<Bound<'py, PyDict>> {
    let n = b.count.len();
    let d = PyDict::new(py);
    let flat3 = |v: Vec<[f64; 3]>| v.into_iter().flatten().collect::<Vec<f64>>();
    d.set_item("xyz", PyArray1::from_vec(py, flat3(b.xyz)).reshape([n, 3])?)?;
    d.set_item("albedo_xyz", PyArray1::from_vec(py, flat3(b.albedo_xyz)).reshape([n, 3])?)?;
    d.set_item("depth", PyArray1::from_vec(py, b.depth))?;
    d.set_item("normal", PyArray1::from_vec(py, flat3(b.normal)).reshape([n, 3])?)?;
    d.set_item("transparent", PyArray1::from_vec(py, b.transparent))?;
    d.set_item("count", PyArray1::from_vec(py, b.count))?;
    match b.spectral {
        Some(s) => d.set_item("spectral", PyArray1::from_vec(py, s))?,
        None => d.set_item("spectral", py.None())?,
    }
    d.set_item("nonfinite", b.nonfinite)?;
    Ok(d)
}

/// A film buffer of `pixels` pixels from the dict of [`sums_dict`]; errors name the array.
fn sums_from_dict(d: &Bound<'_, PyDict>, pixels: usize, spectral_len: Option<usize>) -> PyResult<FilmBuffer> {
    let get = |name: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(name)?.ok_or_else(|| PyValueError::new_err(format!("pass sums: '{name}' is missing")))
    };
    let f64s = |name: &str, per: usize| -> PyResult<Vec<f64>> {
        let a: PyReadonlyArrayDyn<f64> = get(name)?.extract()?;
        let v: Vec<f64> = a.as_array().iter().copied().collect();
        if v.len() != pixels * per {
            return Err(PyValueError::new_err(format!(
                "pass sums: '{name}' has {} values, expected {}",
                v.len(),
                pixels * per
            )));
        }
        Ok(v)
    };
    let rows = |v: Vec<f64>| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>();
    let count: PyReadonlyArray1<u32> = get("count")?.extract()?;
    let count = count.as_array().to_vec();
    if count.len() != pixels {
        return Err(PyValueError::new_err(format!("pass sums: 'count' has {} values, expected {pixels}", count.len())));
    }
    let spectral = match (spectral_len, get("spectral")?.is_none()) {
        (Some(n), false) => Some(f64s("spectral", n)?),
        (None, true) => None,
        _ => return Err(PyValueError::new_err("pass sums: 'spectral' does not match the render's spectral_output")),
    };
    Ok(FilmBuffer {
        xyz: rows(f64s("xyz", 3)?),
        albedo_xyz: rows(f64s("albedo_xyz", 3)?),
        depth: f64s("depth", 1)?,
        normal: rows(f64s("normal", 3)?),
        transparent: f64s("transparent", 1)?,
        count,
        spectral,
        nonfinite: get("nonfinite")?.extract()?,
    })
}

#[pymethods]
impl PassRenderer {
    #[new]
    fn new(py: Python<'_>, scene_json: &str, buffers: Vec<Bound<'_, PyAny>>, settings_json: &str) -> PyResult<Self> {
        let desc: SceneDesc = parse(scene_json, "scene description")?;
        let given = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
        let lent = lend_buffers(&buffers)?;
        let copies = strided_copies(&lent);
        let buffers = views(&lent, &copies);
        py.allow_threads(|| {
            guarded("scene build", || {
                let settings = given.resolve(Some(&desc))?;
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(settings.threads)
                    .build()
                    .map_err(|e| Error::setting("threads", e.to_string()))?;
                let start = std::time::Instant::now();
                let scene = pool.install(|| compile(&desc, &buffers, &settings))?;
                Driver::new(&scene, &settings)?; // settings the scene cannot be rendered with fail here
                Ok(Self {
                    scene,
                    settings,
                    pool,
                    build_seconds: start.elapsed().as_secs_f64(),
                    merge: Mutex::new(None),
                    control: RenderControl::new(),
                })
            })
        })
    }

    /// Sample passes of the whole render (rounds × samples).
    fn sample_passes(&self) -> PyResult<u32> {
        Ok(self.driver()?.sample_passes())
    }

    /// The pass loop's groups as (start, end) ranges, in order.
    fn groups(&self) -> PyResult<Vec<(u32, u32)>> {
        Ok(self.driver()?.groups().into_iter().map(|r| (r.start, r.end)).collect())
    }

    /// Whether adaptive sampling applies (tasks must then keep to the groups).
    fn adaptive(&self) -> PyResult<bool> {
        Ok(self.driver()?.adaptive())
    }

    /// (width, height) of the image.
    fn size(&self) -> (u32, u32) {
        (self.settings.width, self.settings.height)
    }

    /// The resolved time limit in seconds (0: none).
    fn time_limit(&self) -> f64 {
        self.settings.time_limit
    }

    /// Seconds the scene took to compile.
    fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// Sums of sample passes `start..end` over the pixels whose `active` entry is true
    /// (all when None), as numpy arrays: `xyz`, `albedo_xyz`, `normal` (pixels, 3),
    /// `depth`, `count` (pixels,), `spectral` (pixels × wavelengths,) or None, and
    /// `nonfinite`. Renders on this object's thread pool without the GIL; None once
    /// `cancel()` was called.
    ///
    /// `rect` (x0, y0, x1, y1): only the pixels of that rectangle, its sums row-major in
    /// it (image tiles; only when `tileable()`).
    #[pyo3(signature = (start, end, active=None, rect=None))]
    fn render_passes<'py>(
        &self,
        py: Python<'py>,
        start: u32,
        end: u32,
        active: Option<PyReadonlyArray1<'py, bool>>,
        rect: Option<[u32; 4]>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let driver = self.driver()?;
        let total = driver.sample_passes();
        if start >= end || end > total {
            return Err(PyValueError::new_err(format!("passes {start}..{end}: not a range inside 0..{total}")));
        }
        let active = active.map(|a| a.as_array().to_vec());
        if active.as_ref().is_some_and(|a| a.len() != self.pixels()) {
            return Err(PyValueError::new_err(format!("active: expected {} pixels", self.pixels())));
        }
        if let Some(r) = rect {
            self.check_rect(r)?;
            if !driver.tileable() {
                return Err(PyValueError::new_err(
                    "rect: renders with light paths (FORWARD, BIDIRECTIONAL) cannot be cut into tiles",
                ));
            }
        }
        let control = &self.control;
        let sums = py.allow_threads(|| {
            guarded("render_passes", || {
                Ok(self.pool.install(|| match rect {
                    Some(r) => driver.render_rect(start..end, active.as_deref(), r, control),
                    None => driver.render_passes(start..end, active.as_deref(), control),
                }))
            })
        })?;
        sums.map(|s| sums_dict(py, s)).transpose()
    }

    /// Ends the running `render_passes` calls of this object within a tile row, and
    /// every later one: they return None (a local render in tasks that was cancelled).
    fn cancel(&self) {
        self.control.cancel();
    }

    /// Whether `render_passes` may cover image tiles (camera paths only).
    fn tileable(&self) -> PyResult<bool> {
        Ok(self.driver()?.tileable())
    }

    /// Adds a task's sums (from `render_passes` of this scene and settings, with the same
    /// `rect`); `first_half`: the task lies in its group's first half (see `halves`).
    #[pyo3(signature = (sums, first_half, rect=None))]
    fn add(&self, py: Python<'_>, sums: &Bound<'_, PyDict>, first_half: bool, rect: Option<[u32; 4]>) -> PyResult<()> {
        let spectral_len = self.settings.spectral_output.then_some(self.scene.grid.len());
        let pixels = match rect {
            Some(r) => {
                self.check_rect(r)?;
                ((r[2] - r[0]) * (r[3] - r[1])) as usize
            }
            None => self.pixels(),
        };
        let buffer = sums_from_dict(sums, pixels, spectral_len)?;
        py.allow_threads(|| {
            self.with_merge(|_, m| {
                match rect {
                    Some(r) => m.add_rect(&buffer, r, first_half),
                    None => m.add(&buffer, first_half),
                }
                Ok(())
            })
        })
    }

    /// What was added so far, for a checkpoint: the pass sums (as `render_passes`
    /// returns them), `passes` (of the groups ended) and with adaptive sampling
    /// `active`, `half_xyz`, `half_count` and `err` per pixel.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let state = self.with_merge(|_, m| Ok(m.state()))?;
        let d = sums_dict(py, state.buffer)?;
        d.set_item("passes", state.passes)?;
        if let Some(a) = state.adaptive {
            let n = a.active.len();
            d.set_item("active", PyArray1::from_vec(py, a.active))?;
            let flat: Vec<f64> = a.half_xyz.into_iter().flatten().collect();
            d.set_item("half_xyz", PyArray1::from_vec(py, flat).reshape([n, 3])?)?;
            d.set_item("half_count", PyArray1::from_vec(py, a.half_count))?;
            d.set_item("err", PyArray1::from_vec(py, a.err))?;
        }
        Ok(d)
    }

    /// Continues from a dict of `state()` of the same render (ValueError saying what does
    /// not match).
    fn restore(&self, py: Python<'_>, state: &Bound<'_, PyDict>) -> PyResult<()> {
        let spectral_len = self.settings.spectral_output.then_some(self.scene.grid.len());
        let n = self.pixels();
        let buffer = sums_from_dict(state, n, spectral_len)?;
        let get = |name: &str| -> PyResult<Option<Bound<'_, PyAny>>> { state.get_item(name) };
        let passes: u32 =
            get("passes")?.ok_or_else(|| PyValueError::new_err("state: 'passes' is missing"))?.extract()?;
        let adaptive = match get("active")? {
            None => None,
            Some(active) => {
                let need =
                    |name: &str| get(name)?.ok_or_else(|| PyValueError::new_err(format!("state: '{name}' is missing")));
                let active: PyReadonlyArray1<bool> = active.extract()?;
                let half: PyReadonlyArrayDyn<f64> = need("half_xyz")?.extract()?;
                let half: Vec<f64> = half.as_array().iter().copied().collect();
                let half_count: PyReadonlyArray1<u32> = need("half_count")?.extract()?;
                let err: PyReadonlyArray1<f64> = need("err")?.extract()?;
                Some(AdaptiveState {
                    active: active.as_array().to_vec(),
                    half_xyz: half.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                    half_count: half_count.as_array().to_vec(),
                    err: err.as_array().to_vec(),
                })
            }
        };
        let state = MergeState { buffer, passes, adaptive };
        py.allow_threads(|| {
            self.with_merge(|_, m| m.restore(state).map_err(|e| PyValueError::new_err(format!("state: {e}"))))
        })
    }

    /// A group's two halves as (start, end) ranges (without adaptive sampling the first
    /// is the whole group and the second empty).
    fn halves(&self, start: u32, end: u32) -> PyResult<[(u32, u32); 2]> {
        self.with_merge(|_, m| Ok(m.halves(start..end).map(|r| (r.start, r.end))))
    }

    /// After every task of a group of `passes` passes was added.
    fn end_group(&self, passes: u32) -> PyResult<()> {
        self.with_merge(|d, m| {
            // The count is a u32: past it, debug builds panicked and release ones wrapped.
            if m.passes().checked_add(passes).is_none() {
                return Err(PyValueError::new_err(format!(
                    "end_group({passes}): {} passes already ended, the total would exceed {}",
                    m.passes(),
                    u32::MAX
                )));
            }
            m.end_group(d, passes);
            Ok(())
        })
    }

    /// Adaptive sampling: the pixels still sampled (bool per pixel, row-major), or None.
    fn active<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<bool>>>> {
        self.with_merge(|_, m| Ok(m.active().map(|a| PyArray1::from_slice(py, a))))
    }

    /// False once adaptive sampling has stopped every pixel.
    fn any_active(&self) -> PyResult<bool> {
        self.with_merge(|_, m| Ok(m.any_active()))
    }

    /// Passes counted by `end_group` so far.
    fn passes(&self) -> PyResult<u32> {
        self.with_merge(|_, m| Ok(m.passes()))
    }

    /// The dict of `render` for what was added; `cancelled` marks it partial in the stats.
    #[pyo3(signature = (cancelled, time_limited, seconds))]
    fn output<'py>(
        &self,
        py: Python<'py>,
        cancelled: bool,
        time_limited: bool,
        seconds: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let control = RenderControl::new();
        if cancelled {
            control.cancel();
        }
        let start = std::time::Instant::now()
            .checked_sub(Duration::from_secs_f64(seconds.max(0.0)))
            .unwrap_or_else(std::time::Instant::now);
        let timing = Timing { start, build_seconds: self.build_seconds, threads: self.pool.current_num_threads() };
        let mut out = self.with_merge(|d, m| Ok(m.output(d, time_limited, &control, timing)))?;
        out.stats.auto_reason.splice(0..0, self.settings.notes.iter().cloned());
        output_dict(py, out)
    }
}

fn output_dict<'py>(py: Python<'py>, out: RenderOutput) -> PyResult<Bound<'py, PyDict>> {
    let (h, w) = (out.height as usize, out.width as usize);
    let d = PyDict::new(py);
    let n = out.wavelengths.len();
    d.set_item("rgba", PyArray1::from_vec(py, out.images.rgba).reshape([h, w, 4])?)?;
    d.set_item("depth", PyArray1::from_vec(py, out.images.depth).reshape([h, w])?)?;
    d.set_item("normal", PyArray1::from_vec(py, out.images.normal).reshape([h, w, 3])?)?;
    d.set_item("albedo", PyArray1::from_vec(py, out.images.albedo).reshape([h, w, 3])?)?;
    match out.images.spectral {
        Some(s) => d.set_item("spectral", PyArray1::from_vec(py, s).reshape([h, w, n])?)?,
        None => d.set_item("spectral", py.None())?,
    }
    d.set_item("wavelengths", PyArray1::from_vec(py, out.wavelengths))?;
    let stats = serde_json::to_string(&out.stats).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    d.set_item("stats", stats)?;
    Ok(d)
}

/// wavelength_grid(settings_json) -> (wavelengths, quadrature weights) of the settings' grid.
#[pyfunction]
fn wavelength_grid<'py>(
    py: Python<'py>,
    settings_json: &str,
) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>)> {
    let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
    let grid = guarded("wavelength_grid", || Ok(settings.resolve(None)?.grid))?;
    Ok((PyArray1::from_slice(py, grid.lambdas()), PyArray1::from_slice(py, grid.weights())))
}

fn role_from(role: &str) -> PyResult<SpectrumRole> {
    match role {
        "reflectance" => Ok(SpectrumRole::Reflectance),
        "illuminant" => Ok(SpectrumRole::Illuminant),
        "unbounded" => Ok(SpectrumRole::Unbounded),
        _ => Err(PyValueError::new_err(format!("role '{role}': expected reflectance, illuminant or unbounded"))),
    }
}

/// spectrum_values(spectrum_json, settings_json, role="illuminant") -> values on the grid.
#[pyfunction]
#[pyo3(signature = (spectrum_json, settings_json, role="illuminant"))]
fn spectrum_values<'py>(
    py: Python<'py>,
    spectrum_json: &str,
    settings_json: &str,
    role: &str,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let desc: SpectrumDesc = parse(spectrum_json, "spectrum")?;
    let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
    let role = role_from(role)?;
    let values = guarded("spectrum_values", || {
        let grid = settings.resolve(None)?.grid;
        let uplift = Uplift::new(&grid, &RgbSpace::rec709(), settings.uplift)?;
        desc.evaluate(&grid, role, &uplift).map_err(Error::Description)
    })?;
    Ok(PyArray1::from_vec(py, values))
}

/// spectrum_xyz(spectrum_json, settings_json) -> (X, Y, Z) through the grid's CIE 1931
/// observer, normalised so that an equal-energy spectrum of 1 has Y = 1.
#[pyfunction]
fn spectrum_xyz(spectrum_json: &str, settings_json: &str) -> PyResult<(f64, f64, f64)> {
    let desc: SpectrumDesc = parse(spectrum_json, "spectrum")?;
    let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
    let xyz = guarded("spectrum_xyz", || {
        let grid = settings.resolve(None)?.grid;
        let uplift = Uplift::new(&grid, &RgbSpace::rec709(), settings.uplift)?;
        let v = desc.evaluate(&grid, SpectrumRole::Unbounded, &uplift).map_err(Error::Description)?;
        Ok(Observer::new(&grid).xyz(&v))
    })?;
    Ok((xyz[0], xyz[1], xyz[2]))
}

/// uplift(rgb, role, settings_json) -> (..., N) spectra of the (..., 3) float32 RGB
/// array on the settings' grid, through the same code path textures and HDRIs use at a
/// hit: role "reflectance" (clamped to [0,1]) or "illuminant" (unbounded).
#[pyfunction]
fn uplift<'py>(
    py: Python<'py>,
    rgb: PyReadonlyArrayDyn<'py, f32>,
    role: &str,
    settings_json: &str,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f32>>> {
    let settings = RenderSettings::from_json(settings_json).map_err(to_py_err)?;
    let role = role_from(role)?;
    let shape = rgb.as_array().shape().to_vec();
    if shape.last() != Some(&3) {
        return Err(PyValueError::new_err(format!("uplift: rgb must have shape (..., 3), got {shape:?}")));
    }
    let values: Vec<f32> = rgb.as_array().iter().copied().collect();
    let (n, out) = guarded("uplift", || {
        let grid = settings.resolve(None)?.grid;
        let up = Uplift::new(&grid, &RgbSpace::rec709(), settings.uplift)?;
        let n = grid.len();
        let mut out = vec![0.0f32; values.len() / 3 * n];
        for (c, o) in values.chunks_exact(3).zip(out.chunks_exact_mut(n)) {
            let c = [c[0], c[1], c[2]];
            match role {
                SpectrumRole::Reflectance => up.reflectance_into(c, o),
                SpectrumRole::Illuminant => up.illuminant_into(c, o),
                SpectrumRole::Unbounded => o.copy_from_slice(&RgbToSpectrum::convert(&up, c, role)),
            }
        }
        Ok((n, out))
    })?;
    let mut out_shape = shape;
    *out_shape.last_mut().expect("checked above") = n;
    PyArray1::from_vec(py, out).reshape(out_shape)
}

fn tessellation_dict<'py>(py: Python<'py>, t: Tessellation) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (nv, nt) = (t.vertex_count(), t.triangle_count());
    d.set_item("vertices", PyArray1::from_vec(py, t.vertices).reshape([nv, 3])?)?;
    d.set_item("normals", PyArray1::from_vec(py, t.normals).reshape([nv, 3])?)?;
    d.set_item("uvs", PyArray1::from_vec(py, t.uvs).reshape([nv, 2])?)?;
    d.set_item("triangles", PyArray1::from_vec(py, t.triangles).reshape([nt, 3])?)?;
    d.set_item("owner", PyArray1::from_vec(py, t.owner))?;
    Ok(d)
}

fn rows3(a: &PyReadonlyArrayDyn<'_, f32>, what: &str) -> PyResult<Vec<[f32; 3]>> {
    let v: Vec<f32> = a.as_array().iter().copied().collect();
    if !v.len().is_multiple_of(3) {
        return Err(PyValueError::new_err(format!("{what} must have shape (N, 3)")));
    }
    Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// tessellate_curves(name, keys (K, 3) f32, radii (K,) f32, counts (C,) u32,
/// subdivisions, sides, linear) -> dict of vertices, normals, uvs, triangles, owner
/// (the curve of each triangle): curves as tubes (geometry/curves.rs).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn tessellate_curves<'py>(
    py: Python<'py>,
    name: &str,
    keys: PyReadonlyArrayDyn<'py, f32>,
    radii: PyReadonlyArrayDyn<'py, f32>,
    counts: PyReadonlyArrayDyn<'py, u32>,
    subdivisions: u32,
    sides: u32,
    linear: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let k = rows3(&keys, "keys")?;
    let r: Vec<f32> = radii.as_array().iter().copied().collect();
    let c: Vec<u32> = counts.as_array().iter().copied().collect();
    let opts = CurveOptions { subdivisions, sides, linear };
    let t = py.allow_threads(|| guarded("tessellate_curves", || curves::tessellate_curves(name, &k, &r, &c, &opts)))?;
    tessellation_dict(py, t)
}

/// tessellate_points(name, positions (N, 3) f32, radii (N,) f32, level) -> dict as
/// tessellate_curves (owner: the point of each triangle): points as icospheres.
#[pyfunction]
fn tessellate_points<'py>(
    py: Python<'py>,
    name: &str,
    positions: PyReadonlyArrayDyn<'py, f32>,
    radii: PyReadonlyArrayDyn<'py, f32>,
    level: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let p = rows3(&positions, "positions")?;
    let r: Vec<f32> = radii.as_array().iter().copied().collect();
    let t = py.allow_threads(|| guarded("tessellate_points", || curves::tessellate_points(name, &p, &r, level)))?;
    tessellation_dict(py, t)
}

/// settings_schema() -> JSON text: every render setting (name, type, range or enum
/// items, default, help, group, how Blender shows it) and the quality presets; the
/// Python API, the CLI and the Blender add-on are generated from it.
#[pyfunction]
fn settings_schema() -> String {
    schema_json()
}

/// ior_index(ior_json, wavelengths) -> list of float: an index-of-refraction model
/// (`{"type": "abbe", "nd": .., "vd": ..}`, as `polychrome.ior` writes it) at each
/// wavelength in nm, NaN where the model is undefined (e.g. at a Sellmeier pole). The
/// Blender Dispersion node shows these.
#[pyfunction]
fn ior_index(ior_json: &str, wavelengths: Vec<f64>) -> PyResult<Vec<f64>> {
    let ior: IorDesc = parse(ior_json, "index of refraction")?;
    Ok(wavelengths.iter().map(|&l| ior.index_at(l).unwrap_or(f64::NAN)).collect())
}

/// abbe_to_cauchy(nd, vd) -> (A, B in µm²): the two-term Cauchy fit through nd at the d
/// line with nF − nC = (nd − 1)/vd (material/dispersion.rs).
#[pyfunction]
fn abbe_to_cauchy(nd: f64, vd: f64) -> (f64, f64) {
    dispersion::abbe_to_cauchy(nd, vd)
}

/// glass_catalogue() -> list of dict (name, aliases, b, c, nd, vd, source): the named
/// glasses of material/catalogue.rs with their Sellmeier coefficients and sources.
#[pyfunction]
fn glass_catalogue(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    catalogue::CATALOGUE
        .iter()
        .map(|m| {
            let d = PyDict::new(py);
            d.set_item("name", m.name)?;
            d.set_item("aliases", m.aliases.to_vec())?;
            d.set_item("b", m.sellmeier.b.to_vec())?;
            d.set_item("c", m.sellmeier.c.to_vec())?;
            d.set_item("nd", m.nd)?;
            d.set_item("vd", m.vd)?;
            d.set_item("source", m.source)?;
            Ok(d)
        })
        .collect()
}

/// _panic_for_tests(message) — panics inside `guarded` on purpose, so tests can check
/// that an internal panic reaches Python as a RuntimeError and never aborts the process.
#[pyfunction]
fn _panic_for_tests(message: &str) -> PyResult<()> {
    guarded("_panic_for_tests", || -> Result<(), Error> { panic!("{message}") })
}

/// _evaluate_procedural(idname, params_json, points, w) -> {socket name: array}
///
/// Testing hook, not API: evaluates one procedural texture node (Blender idname, e.g.
/// "ShaderNodeTexNoise"; params as in `polychrome_core::procedural`) at the (N, 3)
/// float32 `points` and (N,) float32 `w`, returning each output socket by Blender's
/// name as (N,) or (N, 3) float32. The tests compare it with Cycles.
#[pyfunction]
fn _evaluate_procedural<'py>(
    py: Python<'py>,
    idname: &str,
    params_json: &str,
    points: PyReadonlyArrayDyn<'py, f32>,
    w: PyReadonlyArrayDyn<'py, f32>,
) -> PyResult<Bound<'py, PyDict>> {
    use polychrome_core::procedural::{Procedural, SocketValue};
    let node = Procedural::from_json(idname, params_json).map_err(PyValueError::new_err)?;
    let shape = points.as_array().shape().to_vec();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!("points must have shape (N, 3), got {shape:?}")));
    }
    let n = shape[0];
    if w.as_array().len() != n {
        return Err(PyValueError::new_err(format!("w must have {n} values, got {}", w.as_array().len())));
    }
    let pts: Vec<f32> = points.as_array().iter().copied().collect();
    let ws: Vec<f32> = w.as_array().iter().copied().collect();
    let names = node.output_names();
    let vectors: Vec<bool> =
        node.evaluate(glam::Vec3::ZERO, 0.0).as_slice().iter().map(|v| matches!(v, SocketValue::Vector(_))).collect();
    let columns = guarded("_evaluate_procedural", || {
        let mut columns: Vec<Vec<f32>> = vec![Vec::with_capacity(3 * n); names.len()];
        for (p, &w) in pts.chunks_exact(3).zip(&ws) {
            for (column, value) in
                columns.iter_mut().zip(node.evaluate(glam::Vec3::new(p[0], p[1], p[2]), w).as_slice())
            {
                match *value {
                    SocketValue::Float(v) => column.push(v),
                    SocketValue::Vector(v) => column.extend_from_slice(&v.to_array()),
                }
            }
        }
        Ok(columns)
    })?;
    let out = PyDict::new(py);
    for ((name, column), vector) in names.iter().zip(columns).zip(vectors) {
        let array = PyArray1::from_vec(py, column);
        if vector {
            out.set_item(*name, array.reshape([n, 3])?)?;
        } else {
            out.set_item(*name, array)?;
        }
    }
    Ok(out)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_class::<PassRenderer>()?;
    m.add_function(wrap_pyfunction!(wavelength_grid, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum_values, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum_xyz, m)?)?;
    m.add_function(wrap_pyfunction!(uplift, m)?)?;
    m.add_function(wrap_pyfunction!(tessellate_curves, m)?)?;
    m.add_function(wrap_pyfunction!(tessellate_points, m)?)?;
    m.add_function(wrap_pyfunction!(settings_schema, m)?)?;
    m.add_function(wrap_pyfunction!(ior_index, m)?)?;
    m.add_function(wrap_pyfunction!(abbe_to_cauchy, m)?)?;
    m.add_function(wrap_pyfunction!(glass_catalogue, m)?)?;
    // The Fraunhofer lines of the Abbe number (nm), defined once in material/dispersion.rs.
    m.add("LAMBDA_D", dispersion::LAMBDA_D)?;
    m.add("LAMBDA_F", dispersion::LAMBDA_F)?;
    m.add("LAMBDA_C", dispersion::LAMBDA_C)?;
    m.add_function(wrap_pyfunction!(_panic_for_tests, m)?)?;
    m.add_function(wrap_pyfunction!(_evaluate_procedural, m)?)?;
    m.add_class::<RenderJob>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
