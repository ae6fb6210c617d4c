//! The MPI transport under `mpirun` (feature `mpi`; `make test` installs
//! Open MPI and runs these): compositing over 1–4 ranks equals sequential
//! compositing, and a failing or disagreeing rank stops every rank with
//! the same message.
#![cfg(feature = "mpi")]

use std::process::{Command, Output};

fn mpirun(np: usize, env: &[(&str, &str)]) -> Output {
    let mut c = Command::new("mpirun");
    c.args(["--oversubscribe", "-np", &np.to_string()]);
    // Open MPI refuses root without this (containers and CI run as root).
    if std::env::var("USER").as_deref() == Ok("root")
        || Command::new("id").arg("-u").output().is_ok_and(|o| o.stdout.starts_with(b"0"))
    {
        c.arg("--allow-run-as-root");
    }
    for (k, v) in env {
        c.args(["-x", &format!("{k}={v}")]);
    }
    c.arg(env!("CARGO_BIN_EXE_tet-distributed-selftest"));
    c.output().expect("mpirun runs (Open MPI's openmpi-bin)")
}

#[test]
fn binary_swap_over_mpi_equals_sequential_compositing() {
    for np in 1..=4 {
        let out = mpirun(np, &[]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "np {np}: {text}\n{}", String::from_utf8_lossy(&out.stderr));
        assert!(text.contains(&format!("rank 0: {np} ranks")), "np {np}: {text}");
        assert_eq!(text.matches("bytes in").count(), np, "np {np}: {text}");
    }
}

#[test]
fn a_failing_or_disagreeing_rank_stops_every_rank_with_one_message() {
    for (var, want) in [
        ("TET_SELFTEST_FAIL", "rank 2: simulated failure on rank 2"),
        ("TET_SELFTEST_DISAGREE", "ranks disagree on the request: rank 2 differs from rank 0"),
    ] {
        let out = mpirun(3, &[(var, "2")]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{var}: {err}");
        assert_eq!(err.matches(want).count(), 3, "{var}: every rank says it\n{err}");
        assert!(!String::from_utf8_lossy(&out.stdout).contains("bytes in"), "{var}: nothing composited");
    }
}
