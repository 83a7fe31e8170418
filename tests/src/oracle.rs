//! The client side of the differential-test oracle (`tests/oracle/oracle.py`).
//!
//! One Python process per test binary, started on first use and shared by every test in it
//! (behind a mutex), so thousands of proptest cases cost one interpreter start. Requests and
//! replies are a JSON header plus raw little-endian arrays (see the Python file for the framing).
//!
//! Which Python: `$CAMSIM_ORACLE_PYTHON`, else `.venv/bin/python` at the workspace root (what
//! `scripts/test-all.sh` creates). When the oracle cannot start, [`with_oracle`] says so in one
//! line and, in CI or under the test script, fails the test; in a bare `cargo test` it skips,
//! saying so once.

use std::io::{BufReader, BufWriter, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::{Mutex, OnceLock};

use serde_json::{json, Value};

/// An n-dimensional array crossing the process boundary.
#[derive(Debug, Clone, PartialEq)]
pub enum Array {
    /// 64-bit floats.
    F64(Vec<f64>, Vec<usize>),
    /// 32-bit floats.
    F32(Vec<f32>, Vec<usize>),
    /// 16-bit unsigned integers.
    U16(Vec<u16>, Vec<usize>),
    /// Bytes.
    U8(Vec<u8>, Vec<usize>),
}

impl Array {
    /// A 1-D f64 array.
    pub fn f64(data: Vec<f64>) -> Self {
        let n = data.len();
        Array::F64(data, vec![n])
    }

    /// An f64 array of `shape` (row-major); panics if the sizes disagree (a test bug).
    pub fn f64_shaped(data: Vec<f64>, shape: &[usize]) -> Self {
        assert_eq!(
            data.len(),
            shape.iter().product::<usize>(),
            "array size and shape disagree"
        );
        Array::F64(data, shape.to_vec())
    }

    /// The shape.
    pub fn shape(&self) -> &[usize] {
        match self {
            Array::F64(_, s) | Array::F32(_, s) | Array::U16(_, s) | Array::U8(_, s) => s,
        }
    }

    /// The values as f64, whatever the type.
    pub fn to_f64(&self) -> Vec<f64> {
        match self {
            Array::F64(d, _) => d.clone(),
            Array::F32(d, _) => d.iter().map(|x| *x as f64).collect(),
            Array::U16(d, _) => d.iter().map(|x| *x as f64).collect(),
            Array::U8(d, _) => d.iter().map(|x| *x as f64).collect(),
        }
    }

    fn dtype(&self) -> &'static str {
        match self {
            Array::F64(..) => "f64",
            Array::F32(..) => "f32",
            Array::U16(..) => "u16",
            Array::U8(..) => "u8",
        }
    }

    fn bytes(&self) -> Vec<u8> {
        match self {
            Array::F64(d, _) => d.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Array::F32(d, _) => d.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Array::U16(d, _) => d.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Array::U8(d, _) => d.clone(),
        }
    }

    fn read(dtype: &str, shape: Vec<usize>, r: &mut impl Read) -> Result<Self, String> {
        let n: usize = shape.iter().product();
        let size = match dtype {
            "f64" => 8,
            "f32" => 4,
            "u16" => 2,
            "u8" => 1,
            other => return Err(format!("oracle sent an unknown dtype {other:?}")),
        };
        let mut raw = vec![0u8; n * size];
        r.read_exact(&mut raw)
            .map_err(|e| format!("reading an array from the oracle: {e}"))?;
        Ok(match dtype {
            "f64" => Array::F64(
                raw.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
                shape,
            ),
            "f32" => Array::F32(
                raw.chunks_exact(4)
                    .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
                shape,
            ),
            "u16" => Array::U16(
                raw.chunks_exact(2)
                    .map(|c| u16::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
                shape,
            ),
            _ => Array::U8(raw, shape),
        })
    }
}

/// A reply: named values and arrays.
#[derive(Debug, Clone)]
pub struct Reply {
    /// JSON values the op returned.
    pub values: Value,
    /// Arrays the op returned, in order.
    pub arrays: Vec<Array>,
}

/// A running oracle process.
pub struct Oracle {
    child: Child,
    stdin: BufWriter<ChildStdin>,
    stdout: BufReader<ChildStdout>,
    /// Package versions the oracle reported at start.
    pub versions: Value,
}

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

impl Oracle {
    /// Starts the helper and checks it answers.
    pub fn spawn() -> Result<Self, String> {
        let python = std::env::var_os("CAMSIM_ORACLE_PYTHON")
            .map(PathBuf::from)
            .unwrap_or_else(|| workspace_root().join(".venv/bin/python"));
        if !python.exists() {
            return Err(format!(
                "no oracle Python at {} (scripts/test-all.sh creates it; or set CAMSIM_ORACLE_PYTHON)",
                python.display()
            ));
        }
        let script = workspace_root().join("tests/oracle/oracle.py");
        let mut child = Command::new(&python)
            .arg(&script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| {
                format!(
                    "cannot start {} {}: {e}",
                    python.display(),
                    script.display()
                )
            })?;
        let stdin = BufWriter::new(child.stdin.take().ok_or("no stdin")?);
        let stdout = BufReader::new(child.stdout.take().ok_or("no stdout")?);
        let mut oracle = Oracle {
            child,
            stdin,
            stdout,
            versions: Value::Null,
        };
        let reply = oracle.call("ping", json!({}), &[])?;
        oracle.versions = reply.values["versions"].clone();
        Ok(oracle)
    }

    /// Runs `op` with `args` and `arrays`; an error carries the oracle's own message.
    pub fn call(&mut self, op: &str, args: Value, arrays: &[Array]) -> Result<Reply, String> {
        let specs: Vec<Value> = arrays
            .iter()
            .map(|a| json!({"dtype": a.dtype(), "shape": a.shape()}))
            .collect();
        let header = serde_json::to_vec(&json!({"op": op, "args": args, "arrays": specs})).unwrap();
        let send = |w: &mut BufWriter<ChildStdin>| -> std::io::Result<()> {
            w.write_all(&(header.len() as u32).to_le_bytes())?;
            w.write_all(&header)?;
            for a in arrays {
                w.write_all(&a.bytes())?;
            }
            w.flush()
        };
        send(&mut self.stdin).map_err(|e| format!("oracle stopped reading ({op}): {e}"))?;
        let mut len = [0u8; 4];
        self.stdout
            .read_exact(&mut len)
            .map_err(|e| format!("oracle closed its reply stream ({op}): {e}"))?;
        let mut raw = vec![0u8; u32::from_le_bytes(len) as usize];
        self.stdout
            .read_exact(&mut raw)
            .map_err(|e| format!("oracle reply cut short ({op}): {e}"))?;
        let reply: Value =
            serde_json::from_slice(&raw).map_err(|e| format!("oracle reply is not JSON: {e}"))?;
        let mut out = Vec::new();
        for spec in reply["arrays"].as_array().cloned().unwrap_or_default() {
            let shape = spec["shape"]
                .as_array()
                .unwrap()
                .iter()
                .map(|d| d.as_u64().unwrap() as usize)
                .collect();
            out.push(Array::read(
                spec["dtype"].as_str().unwrap_or(""),
                shape,
                &mut self.stdout,
            )?);
        }
        if reply["ok"].as_bool() != Some(true) {
            return Err(format!(
                "oracle error: {}",
                reply["error"].as_str().unwrap_or("(none given)")
            ));
        }
        Ok(Reply {
            values: reply["values"].clone(),
            arrays: out,
        })
    }
}

impl Drop for Oracle {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

static ORACLE: OnceLock<Mutex<Result<Oracle, String>>> = OnceLock::new();
static SKIP_REPORTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a missing oracle is a failure: in CI, and in the README's test command
/// (`scripts/test-all.sh` sets `CAMSIM_REQUIRE_ORACLE`, having just created the environment).
pub fn oracle_required() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
        || std::env::var_os("CAMSIM_REQUIRE_ORACLE").is_some()
}

/// Runs `f` with the shared oracle. When the oracle is unavailable: where it is required
/// ([`oracle_required`]), panics with one line saying why; otherwise prints that line once per
/// test binary and returns `None` (the test skips).
pub fn with_oracle<R>(f: impl FnOnce(&mut Oracle) -> R) -> Option<R> {
    let cell = ORACLE.get_or_init(|| {
        let started = Oracle::spawn();
        if let Ok(o) = &started {
            eprintln!("oracle: {}", o.versions);
        }
        Mutex::new(started)
    });
    // A test that failed while holding the lock leaves the oracle usable for the others.
    let mut guard = cell.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    match &mut *guard {
        Ok(oracle) => Some(f(oracle)),
        Err(reason) => {
            let line = format!("oracle unavailable: {reason}");
            if oracle_required() {
                panic!("{line} (required here: CI or CAMSIM_REQUIRE_ORACLE is set)");
            }
            if !SKIP_REPORTED.swap(true, std::sync::atomic::Ordering::Relaxed) {
                eprintln!("{line}; skipping the oracle tests of this binary (outside CI)");
            }
            None
        }
    }
}

/// Calls `op` on the shared oracle and returns its arrays, or `None` when skipping (see
/// [`with_oracle`]). An oracle-side error fails the test.
pub fn oracle_arrays(op: &str, args: Value, arrays: &[Array]) -> Option<Vec<Array>> {
    with_oracle(|o| o.call(op, args, arrays)).map(|r| r.unwrap_or_else(|e| panic!("{e}")).arrays)
}
