//! Training one model on several processes with MPI (feature `mpi`), as the
//! paper (4 workers) and HER baselines do: `mpirun -np 4 fmsr train --config ...`.
//!
//! Every rank runs the same trainer on its own environments, with its own
//! episode seeds and exploration stream, and its own replay buffer. Gradients
//! are averaged over the ranks before every optimiser step (HER baselines' MPI
//! Adam), as are the normalisers' statistics and MASAC's temperature
//! gradients, so the networks stay identical; every rank's occupancy estimate
//! observes the episodes of all ranks. Rank 0 writes the configuration, the
//! logs and every rank's checkpoint files. A rank that fails prints its error
//! with its rank and aborts the whole job ([`MpiCommunicator::abort`]), so the
//! others never wait for it.
//!
//! Needs an MPI library at build and run time (Debian: `libopenmpi-dev`,
//! `openmpi-bin` and `libclang-dev` for the bindings; `scripts/setup_mpi.sh`).

use std::sync::Mutex;

use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator as _, CommunicatorCollectives, Destination, Source};
use thiserror::Error;

/// Why MPI could not be started.
#[derive(Debug, Error)]
pub enum MpiError {
    /// `MPI_Init_thread` failed or MPI was already initialised.
    #[error("MPI could not be initialised (is this binary started by mpirun?)")]
    Init,
    /// The MPI library cannot serialise calls from several threads.
    #[error("the MPI library offers thread support {0:?}; fmsr needs at least Serialized")]
    Threading(mpi::Threading),
}

/// MPI, initialised for the life of this value (finalised when dropped).
pub struct Mpi {
    universe: mpi::environment::Universe,
}

impl std::fmt::Debug for Mpi {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mpi").finish_non_exhaustive()
    }
}

impl Mpi {
    /// Initialises MPI with serialised thread support.
    ///
    /// # Errors
    /// [`MpiError`] when MPI cannot start or cannot serialise threads.
    pub fn init() -> Result<Self, MpiError> {
        let (universe, threading) = mpi::initialize_with_threading(mpi::Threading::Serialized).ok_or(MpiError::Init)?;
        if threading < mpi::Threading::Serialized {
            return Err(MpiError::Threading(threading));
        }
        Ok(Self { universe })
    }

    /// The world communicator, as an fmsr [`Communicator`](fmsr_core::agent::Communicator).
    #[must_use]
    pub fn communicator(&self) -> MpiCommunicator {
        let world = self.universe.world();
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        MpiCommunicator { world: Mutex::new(World(world)), rank, size }
    }
}

/// The MPI world communicator behind a lock.
struct World(SimpleCommunicator);

// SAFETY: MPI is initialised with `Threading::Serialized` (checked in
// `Mpi::init`), which allows MPI calls from any thread as long as no two run at
// once; every call goes through the `Mutex` in `MpiCommunicator`.
unsafe impl Send for World {}

/// An fmsr [`Communicator`](fmsr_core::agent::Communicator) over MPI's world.
pub struct MpiCommunicator {
    world: Mutex<World>,
    rank: usize,
    size: usize,
}

impl std::fmt::Debug for MpiCommunicator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MpiCommunicator").field("rank", &self.rank).field("size", &self.size).finish()
    }
}

impl MpiCommunicator {
    fn with<T>(&self, f: impl FnOnce(&SimpleCommunicator) -> T) -> T {
        let world = self.world.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        f(&world.0)
    }

    /// Ends every rank of the job (`MPI_Abort`) with `code`.
    pub fn abort(&self, code: i32) -> ! {
        self.with(|w| w.abort(code))
    }
}

impl fmsr_core::agent::Communicator for MpiCommunicator {
    fn workers(&self) -> usize {
        self.size
    }

    fn rank(&self) -> usize {
        self.rank
    }

    fn all_reduce_mean(&self, values: &mut [f32]) {
        let mut sum = vec![0.0f32; values.len()];
        self.with(|w| w.all_reduce_into(&values[..], &mut sum[..], SystemOperation::sum()));
        let n = self.size as f32;
        values.iter_mut().zip(sum).for_each(|(v, s)| *v = s / n);
    }

    fn all_gather(&self, local: &[f32]) -> Vec<f32> {
        let mut all = vec![0.0f32; local.len() * self.size];
        self.with(|w| w.all_gather_into(local, &mut all[..]));
        all
    }

    fn gather_bytes(&self, local: Vec<u8>) -> Option<Vec<Vec<u8>>> {
        self.with(|w| {
            if self.rank != 0 {
                w.process_at_rank(0).send(&local[..]);
                return None;
            }
            let mut all = Vec::with_capacity(self.size);
            all.push(local);
            for r in 1..self.size {
                all.push(w.process_at_rank(r as i32).receive_vec::<u8>().0);
            }
            Some(all)
        })
    }
}
