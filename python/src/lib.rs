//! `atmosim._atmosim`: the Python extension of atmosim, a thin layer over
//! the library. Each function does what the binary's subcommand does with
//! the same library calls (`src/cli/*.rs`), and hands the results to
//! Python as plain lists and numpy arrays; the labelling (dimensions,
//! coordinates, units) is done by the Python package `atmosim`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use atmosim::io::exr::read_exr;
use atmosim::job::{Job, Sensor};
use atmosim::physics::solar::SolarSpectrum;
use atmosim::run::layout::Layout;
use atmosim::run::merge::task_dir;
use atmosim::run::out_dir::Destination;
use atmosim::run::shard::Shard;
use atmosim::run::task_output::{self, RunInfo};
use atmosim::run::work_unit::{self, Control, Outcome};
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::queries;
use atmosim::skymodel::runtime::Model;
use atmosim::transport::table_build::transmittance_table;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyFileNotFoundError, PyKeyError, PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use rayon::prelude::*;

/// The library's error as the Python exception a user expects: a file
/// that is not there is a `FileNotFoundError`, other I/O errors an
/// `OSError`, and everything a user's input causes (the binary's exit 2:
/// a bad job key, a malformed data file) a `ValueError` with the
/// library's message, which names the file, the key and the valid range.
fn to_py(e: atmosim::Error) -> PyErr {
    match &e {
        atmosim::Error::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        atmosim::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ if e.is_user_error() => PyValueError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// A validated job (`atmosim::job::Job`).
#[pyclass(name = "_Job", module = "atmosim._atmosim", frozen)]
struct PyJob {
    job: Job,
}

/// A Python value of a job dict as TOML; `key` names it in errors.
fn toml_value(value: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(value.extract()?));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(value.extract()?));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        return Ok(toml::Value::Table(toml_table(dict, key)?));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = value.try_iter()?.map(|item| toml_value(&item?, key)).collect();
        return Ok(toml::Value::Array(items?));
    }
    // numpy scalars and arrays.
    if value.hasattr("tolist")? {
        return toml_value(&value.call_method0("tolist")?, key);
    }
    Err(PyTypeError::new_err(format!(
        "job key `{key}`: a {} is not a job value (numbers, strings, booleans, lists and dicts are)",
        value.get_type().name()?
    )))
}

fn toml_table(dict: &Bound<'_, PyDict>, prefix: &str) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    for (k, v) in dict.iter() {
        let name: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "job keys are strings, not {}",
                k.repr().map_or("?".into(), |r| r.to_string())
            ))
        })?;
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        // None: the key is left out (its default).
        if v.is_none() {
            continue;
        }
        table.insert(name, toml_value(&v, &key)?);
    }
    Ok(table)
}

#[pymethods]
impl PyJob {
    /// Reads and resolves a job file, as `atmosim render JOB` does.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<PyJob> {
        Ok(PyJob {
            job: Job::from_file(&path).map_err(to_py)?,
        })
    }

    /// Resolves job text; `file` names it in errors, relative paths resolve from `dir`.
    #[staticmethod]
    fn from_text(text: &str, file: &str, dir: PathBuf) -> PyResult<PyJob> {
        Ok(PyJob {
            job: Job::parse(text, file, &dir).map_err(to_py)?,
        })
    }

    /// The TOML text of a job dict (the same schema as a job file).
    #[staticmethod]
    fn dict_to_toml(dict: &Bound<'_, PyDict>) -> PyResult<String> {
        let table = toml_table(dict, "")?;
        toml::to_string(&table).map_err(|e| PyValueError::new_err(format!("the job dict is not a TOML table: {e}")))
    }

    #[getter]
    fn text(&self) -> &str {
        &self.job.text
    }
    #[getter]
    fn file(&self) -> &str {
        &self.job.file
    }
    #[getter]
    fn hash(&self) -> &str {
        &self.job.hash
    }
    #[getter]
    fn wavelengths_nm(&self) -> Vec<f64> {
        self.job.wavelengths_nm.clone()
    }
    #[getter]
    fn band_widths_nm(&self) -> Vec<f64> {
        self.job.band_widths_nm.clone()
    }
    #[getter]
    fn albedos(&self) -> Vec<f64> {
        self.job.render.albedos.clone()
    }
    #[getter]
    fn sensor(&self) -> &'static str {
        match self.job.render.sensor {
            Sensor::Directions(_) => "directions",
            Sensor::Image(_) => "image",
        }
    }
    /// The tasks: (name, visibility km or None, sun zenith deg, observer altitude km).
    #[getter]
    fn tasks(&self) -> Vec<(String, Option<f64>, f64, f64)> {
        self.job
            .tasks
            .iter()
            .map(|t| {
                (
                    t.name.clone(),
                    t.visibility_km,
                    t.sun.zenith_deg,
                    t.observer_altitude_km,
                )
            })
            .collect()
    }
    /// The transmittance tasks: (name, visibility km or None, observer altitude km).
    #[getter]
    fn transmittance_tasks(&self) -> Vec<(String, Option<f64>, f64)> {
        self.job
            .transmittance_tasks()
            .into_iter()
            .map(|(t, name)| (name, t.visibility_km, t.observer_altitude_km))
            .collect()
    }

    /// An image sensor's viewing direction at every pixel centre: view
    /// zenith and azimuth (degrees, row-major, row 0 at the top; NaN outside
    /// a fisheye's circle), and the image's (width, height).
    fn pixel_directions(&self) -> PyResult<(Vec<f64>, Vec<f64>, usize, usize)> {
        let Sensor::Image(camera) = &self.job.render.sensor else {
            return Err(PyValueError::new_err("the job's sensor is not an image"));
        };
        let (width, height) = camera.size();
        let mut zenith = Vec::with_capacity(width * height);
        let mut azimuth = Vec::with_capacity(width * height);
        for j in 0..height {
            for i in 0..width {
                match camera.ray_at(i as f64 + 0.5, j as f64 + 0.5) {
                    Some(ray) => {
                        zenith.push(ray.direction.z.clamp(-1.0, 1.0).acos().to_degrees());
                        azimuth.push(ray.azimuth.to_degrees());
                    }
                    None => {
                        zenith.push(f64::NAN);
                        azimuth.push(f64::NAN);
                    }
                }
            }
        }
        Ok((zenith, azimuth, width, height))
    }
}

/// Renders every task of `job` into `out` (a task's directory as
/// `atmosim render JOB --out OUT` names it) with the binary's library
/// calls: the same sums, the same files. The GIL is released while the
/// tasks render; every 50 ms this thread takes it to run Python's signal
/// handlers (a KeyboardInterrupt stops the render after its current wave,
/// about a second) and to call `progress(done, total)` with the paths
/// traced. Returns the tasks' (name, directory).
#[pyfunction]
#[pyo3(signature = (job, out, threads=None, progress=None, overwrite=false))]
fn render(
    py: Python<'_>,
    job: &PyJob,
    out: PathBuf,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
    overwrite: bool,
) -> PyResult<Vec<(String, PathBuf)>> {
    let job = &job.job;
    let destination = Destination::of(job, Some(&out));
    destination.check_writable().map_err(to_py)?;
    let dirs: Vec<PathBuf> = job.tasks.iter().map(|t| task_dir(&destination.dir, job, t)).collect();
    destination
        .check_not_another_job(job, &dirs, overwrite)
        .map_err(to_py)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("starting worker threads: {e}")))?;
    let stop = AtomicBool::new(false);
    let done = AtomicU64::new(0);
    let total = AtomicU64::new(0);
    let worker = || -> atmosim::Result<bool> {
        let mut units = Vec::new();
        for task in &job.tasks {
            let layout = Layout::new(job, task, job.spectral_scene(task).is_some());
            let state = layout.empty_state(job, task, Shard::WHOLE);
            total.fetch_add(layout.paths(Shard::WHOLE), Ordering::Relaxed);
            units.push((task, layout, state));
        }
        for ((task, layout, state), dir) in units.iter_mut().zip(&dirs) {
            let inc = |n: u64| {
                done.fetch_add(n, Ordering::Relaxed);
            };
            let grow = |n: u64| {
                total.fetch_add(n, Ordering::Relaxed);
            };
            let control = Control {
                stop: &stop,
                checkpoint_every: None,
                checkpoint: &|_| Ok(()),
                progress: &inc,
                allocated: &grow,
            };
            let shared = job.spectral_scene(task);
            let outcome = pool.install(|| work_unit::run(job, task, layout, shared, state, &control))?;
            if let Outcome::Stopped { .. } = outcome {
                return Ok(false);
            }
            task_output::write(dir, job, task, layout, state, RunInfo { shards: 1 })?;
        }
        Ok(true)
    };
    let mut python_error: Option<PyErr> = None;
    let outcome = std::thread::scope(|s| {
        let handle = s.spawn(worker);
        while !handle.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(50)));
            if python_error.is_some() {
                continue;
            }
            let step = py.check_signals().and_then(|()| match &progress {
                Some(f) => f
                    .call1(py, (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed)))
                    .map(|_| ()),
                None => Ok(()),
            });
            if let Err(e) = step {
                stop.store(true, Ordering::SeqCst);
                python_error = Some(e);
            }
        }
        handle.join()
    });
    let outcome = outcome.map_err(|_| PyRuntimeError::new_err("the render panicked"))?;
    if let Some(e) = python_error {
        return Err(e);
    }
    match outcome.map_err(to_py)? {
        true => {
            if let Some(f) = &progress {
                f.call1(py, (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed)))?;
            }
            Ok(job.tasks.iter().map(|t| t.name.clone()).zip(dirs).collect())
        }
        false => Err(PyRuntimeError::new_err("the render stopped before its end")),
    }
}

/// The optical properties of the job's atmosphere (its first task's), as
/// `atmosim atmosphere` prints them: per wavelength and layer the optical
/// depths (layer thickness × coefficient), the aerosol's g and the
/// Rayleigh depolarisation.
#[pyfunction]
fn atmosphere<'py>(py: Python<'py>, job: &PyJob) -> PyResult<Bound<'py, PyDict>> {
    let atm = &job.job.atmosphere;
    let layers = atm.levels_km.len() - 1;
    let d = PyDict::new(py);
    d.set_item("wavelength_nm", atm.wavelengths_nm.clone())?;
    d.set_item("bottom_km", atm.levels_km[..layers].to_vec())?;
    d.set_item("top_km", atm.levels_km[1..].to_vec())?;
    let per = |f: &dyn Fn(&atmosim::atmosphere::optics::Optics, f64) -> f64| -> Vec<f64> {
        atm.optics
            .iter()
            .flat_map(|row| row.iter().enumerate().map(|(i, o)| f(o, atm.thickness_km(i))))
            .collect()
    };
    d.set_item("tau_rayleigh", per(&|o, dz| o.sigma_rayleigh * dz))?;
    d.set_item("tau_ozone", per(&|o, dz| o.sigma_absorption * dz))?;
    d.set_item("tau_aerosol_ext", per(&|o, dz| o.sigma_aerosol_ext * dz))?;
    d.set_item("tau_aerosol_sca", per(&|o, dz| o.sigma_aerosol_sca * dz))?;
    d.set_item("aerosol_g", per(&|o, _| o.aerosol_g))?;
    d.set_item("rayleigh_depolarization", per(&|o, _| o.rayleigh_depolarization))?;
    Ok(d)
}

/// Every transmittance table of the job, as `atmosim transmittance`
/// computes them: per table (name, T, its standard error, blocked), T and
/// its error per wavelength then node (altitude-major), with the grid.
#[allow(clippy::type_complexity)]
#[pyfunction]
#[pyo3(signature = (job, threads=None))]
fn transmittance(
    py: Python<'_>,
    job: &PyJob,
    threads: Option<usize>,
) -> PyResult<(
    Vec<(String, Vec<f64>, Vec<f64>, Vec<bool>)>,
    Vec<f64>,
    Vec<f64>,
    String,
    String,
    bool,
    u64,
)> {
    let job = &job.job;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("starting worker threads: {e}")))?;
    let tables = py.detach(|| {
        job.transmittance_tasks()
            .into_iter()
            .map(|(task, name)| {
                let table = pool.install(|| transmittance_table(job, task));
                (name, table.t.concat(), table.se.concat(), table.blocked)
            })
            .collect::<Vec<_>>()
    });
    let spec = &job.transmittance;
    Ok((
        tables,
        spec.grid.altitudes_km.clone(),
        spec.grid.distances_km.clone(),
        spec.grid.definition.clone(),
        spec.estimator.name().to_string(),
        spec.export_sqrt,
        spec.samples,
    ))
}

/// The channels and text attributes of an EXR atmosim wrote:
/// (width, height, [(channel, float32 samples row-major)], [(key, value)]).
#[allow(clippy::type_complexity)]
#[pyfunction]
fn read_exr_file<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(
    usize,
    usize,
    Vec<(String, Bound<'py, PyArray1<f32>>)>,
    Vec<(String, String)>,
)> {
    let contents = py.detach(|| read_exr(&path)).map_err(to_py)?;
    let channels = contents
        .channels
        .into_iter()
        .map(|c| (c.name, PyArray1::from_vec(py, c.samples)))
        .collect();
    Ok((contents.width, contents.height, channels, contents.attributes))
}

/// A sky-model dataset and its runtime (`atmosim eval`'s).
#[pyclass(name = "_SkyModel", module = "atmosim._atmosim", frozen)]
struct PySkyModel {
    model: Model,
    info: String,
}

#[pymethods]
impl PySkyModel {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<PySkyModel> {
        let load = |path: &Path| -> atmosim::Result<(Model, String)> {
            let dataset = Dataset::read(path)?;
            let name = path.display().to_string();
            let info = format!("{name}: {dataset}");
            Ok((Model::new(&name, dataset, SolarSpectrum::kurucz()?)?, info))
        };
        let (model, info) = py.detach(|| load(&path)).map_err(to_py)?;
        Ok(PySkyModel { model, info })
    }

    /// What `atmosim eval DATASET --info` prints.
    #[getter]
    fn info(&self) -> &str {
        &self.info
    }

    /// The dataset's axes: visibilities (km), albedos, altitudes (m),
    /// sun elevations (deg), the channels' start and width (nm), channels,
    /// and whether it has a polarisation part.
    #[allow(clippy::type_complexity)]
    #[getter]
    fn axes(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, f64, f64, usize, bool) {
        let d = self.model.dataset();
        let a = &d.axes;
        (
            a.visibilities_km.clone(),
            a.albedos.clone(),
            a.altitudes_m.clone(),
            a.elevations_deg.clone(),
            a.channel_start_nm,
            a.channel_width_nm,
            a.channels,
            d.polarisation.is_some(),
        )
    }

    /// Evaluates `quantity` (sky_radiance, sun_radiance, polarisation or
    /// transmittance) for every query: `columns` are the 12 columns of
    /// `atmosim eval --queries` (`queries::COLUMNS`), contiguous float64
    /// arrays of one length. Every query is checked first (a `ValueError`
    /// naming the query and the column); the queries are answered in
    /// parallel with the GIL released.
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        quantity: &str,
        columns: Vec<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        if columns.len() != queries::COLUMNS.len() {
            return Err(PyValueError::new_err(format!(
                "{} columns given, {} needed ({})",
                columns.len(),
                queries::COLUMNS.len(),
                queries::COLUMNS.join(", ")
            )));
        }
        let which = match quantity {
            "sky_radiance" => 0,
            "sun_radiance" => 1,
            "polarisation" => 2,
            "transmittance" => 3,
            _ => return Err(PyKeyError::new_err(format!("no quantity {quantity:?}"))),
        };
        if which == 2 && self.model.dataset().polarisation.is_none() {
            return Err(PyValueError::new_err(format!(
                "{}: the dataset has no polarisation part",
                self.info.split(": ").next().unwrap_or("")
            )));
        }
        let slices: Vec<&[f64]> = columns
            .iter()
            .map(|c| c.as_slice().map_err(|e| PyValueError::new_err(e.to_string())))
            .collect::<PyResult<_>>()?;
        let n = slices[0].len();
        if slices.iter().any(|s| s.len() != n) {
            return Err(PyValueError::new_err("the query columns differ in length"));
        }
        let row = |i: usize| -> [f64; 12] { std::array::from_fn(|k| slices[k][i]) };
        let model = &self.model;
        let answers = py.detach(|| -> Result<Vec<f64>, String> {
            // The whole input is checked before the first answer, as the binary does.
            if let Some((i, message)) = (0..n)
                .into_par_iter()
                .find_map_first(|i| queries::check(&row(i)).err().map(|m| (i, m)))
            {
                return Err(format!("query {i}: {message}"));
            }
            Ok((0..n)
                .into_par_iter()
                .with_min_len(1024)
                .map(|i| {
                    let (p, lambda, distance) = queries::parameters(&row(i));
                    match which {
                        0 => model.sky_radiance(&p, lambda),
                        1 => model.sun_radiance(&p, lambda),
                        2 => model.polarisation(&p, lambda).unwrap_or(f64::NAN),
                        _ => model.transmittance(&p, lambda, distance),
                    }
                })
                .collect())
        });
        let answers = answers.map_err(PyValueError::new_err)?;
        Ok(PyArray1::from_vec(py, answers))
    }
}

#[pymodule]
fn _atmosim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyJob>()?;
    m.add_class::<PySkyModel>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(atmosphere, m)?)?;
    m.add_function(wrap_pyfunction!(transmittance, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr_file, m)?)?;
    m.add("QUERY_COLUMNS", queries::COLUMNS.to_vec())?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
