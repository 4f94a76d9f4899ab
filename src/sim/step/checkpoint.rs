//! Rolling a step back ([`Checkpoint`]) and saving or resuming the whole
//! state ([`Snapshot`]).

use super::*;

/// Everything a step changes, kept to roll a failed step back
/// ([`Simulator::checkpoint`]).
#[derive(Clone, Debug, Default)]
pub struct Checkpoint {
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    time: f64,
    resting_on: Vec<u32>,
    released: Vec<bool>,
    normal_force: Vec<f64>,
    contact_impulse: Vec<f64>,
    last_step: LocalError,
    collision: Option<CollisionMemory>,
    /// A fabric change in progress: it recomputes the coefficients of each
    /// step from its step count, so restoring it is enough.
    ramp: Option<Ramp>,
}

impl Simulator {
    /// Stores the state a step changes into `into` (reusing its buffers).
    pub fn checkpoint(&self, into: &mut Checkpoint) {
        into.x.clone_from(&self.x);
        into.v.clone_from(&self.v);
        into.time = self.time;
        into.resting_on.clone_from(&self.resting_on);
        into.released.clone_from(&self.released);
        into.normal_force.clone_from(&self.normal_force);
        into.contact_impulse.clone_from(&self.contact_impulse);
        into.last_step = self.last_step;
        if let Some(pipeline) = &self.collision {
            pipeline.save_memory(into.collision.get_or_insert_with(CollisionMemory::default));
        }
        into.ramp.clone_from(&self.ramp);
    }

    /// Returns to the state of `checkpoint`, taken from this simulator.
    pub fn restore(&mut self, checkpoint: &Checkpoint) {
        self.x.clone_from(&checkpoint.x);
        self.v.clone_from(&checkpoint.v);
        self.time = checkpoint.time;
        self.resting_on.clone_from(&checkpoint.resting_on);
        self.released.clone_from(&checkpoint.released);
        self.normal_force.clone_from(&checkpoint.normal_force);
        self.contact_impulse.clone_from(&checkpoint.contact_impulse);
        self.last_step = checkpoint.last_step;
        if let (Some(pipeline), Some(memory)) = (&mut self.collision, &checkpoint.collision) {
            pipeline.restore_memory(memory);
        }
        self.ramp.clone_from(&checkpoint.ramp);
    }

    /// Its whole state between steps, for a bake to go on later exactly
    /// where it is now ([`crate::sim::snapshot`]). Refused while a fabric change
    /// is being blended in.
    pub fn snapshot(&self) -> Result<Snapshot, SnapshotError> {
        if self.ramp.is_some() {
            return Err(SnapshotError::TuningInProgress);
        }
        Ok(Snapshot { factor: self.preconditioner.state(), ..self.state() })
    }

    /// Its state between steps without the kept factor (the next step
    /// rebuilds one), taken even while a fabric change blends in: what the
    /// editor keeps of each frame to simulate again from it
    /// ([`Self::restart_from`]).
    pub fn state(&self) -> Snapshot {
        let memory = self.collision.as_ref().map(|pipeline| {
            let mut memory = CollisionMemory::default();
            pipeline.save_memory(&mut memory);
            memory.entries()
        });
        let mut warm_start = to_arrays(&self.ws.velocity_change);
        warm_start.resize(self.x.len(), [0.0; 3]);
        Snapshot {
            time_s: self.time,
            positions: to_arrays(&self.x),
            velocities: to_arrays(&self.v),
            resting_on: self.resting_on.clone(),
            released: self.released.clone(),
            normal_force_n: self.normal_force.clone(),
            last_step: self.last_step,
            warm_start,
            contact_influence: memory.unwrap_or_default(),
            factor: None,
        }
    }

    /// Puts this simulator (built from the same scene) in the state of
    /// `snapshot`: the steps after it are bit-identical to those the
    /// snapshotted simulator would have taken.
    pub fn resume_from(&mut self, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        let keeps_factor = matches!(self.preconditioner, Preconditioner::Cholesky(_));
        snapshot.check(self.x.len(), self.colliders.len(), keeps_factor)?;
        if let Some(factor) = &snapshot.factor {
            self.preconditioner.restore(factor)?;
        }
        self.take_state(snapshot);
        Ok(())
    }

    /// Puts this simulator in the state of `snapshot`, with or without a
    /// kept factor ([`Self::state`]): the editor simulating again from a
    /// frame, its current fabric blended in already. Without the factor the
    /// steps after are those of the run it left to within the solver's
    /// tolerance.
    pub fn restart_from(&mut self, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        let keeps_factor = matches!(self.preconditioner, Preconditioner::Cholesky(_));
        snapshot.check(self.x.len(), self.colliders.len(), keeps_factor && snapshot.factor.is_some())?;
        if let Some(factor) = &snapshot.factor {
            self.preconditioner.restore(factor)?;
        }
        self.take_state(snapshot);
        Ok(())
    }

    /// The state of `snapshot` but its factor (checked already).
    fn take_state(&mut self, snapshot: &Snapshot) {
        self.time = snapshot.time_s;
        from_arrays(&snapshot.positions, &mut self.x);
        from_arrays(&snapshot.velocities, &mut self.v);
        from_arrays(&snapshot.warm_start, &mut self.ws.velocity_change);
        self.resting_on.clone_from(&snapshot.resting_on);
        self.released.clone_from(&snapshot.released);
        self.normal_force.clone_from(&snapshot.normal_force_n);
        self.last_step = snapshot.last_step;
        if let Some(pipeline) = &mut self.collision {
            pipeline.restore_memory(&CollisionMemory::from_entries(&snapshot.contact_influence));
        }
    }
}
