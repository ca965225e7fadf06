//! Views into the networks for tests and tools: trunks, parameters, Q-values.

use burn::module::Module;

use crate::error::{NnError, check_values};
use crate::group::{CriticInput, to_vec1};

use super::{Learner, matrix};

impl Learner {
    /// Agent `agent`'s actor trunk, flattened (what sharing mixes), for inspection.
    pub(crate) fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let flats = group.nets.actors.to_flats(&group.actor_layout)?;
        Ok(flats[k][group.actor_layout.shapes[k].trunk()].to_vec())
    }

    /// Replaces agent `agent`'s actor trunk.
    pub(crate) fn set_actor_trunk(&mut self, agent: usize, trunk: &[f32]) -> Result<(), NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &mut self.groups[g];
        let range = group.actor_layout.shapes[k].trunk();
        check_values(|| format!("actor trunk of agent {agent}"), trunk, range.len())?;
        let mut flats = group.nets.actors.to_flats(&group.actor_layout)?;
        flats[k][range].copy_from_slice(trunk);
        group.nets.actors = group.nets.actors.with_flats(&group.actor_layout, &flats);
        group.act_cache = None;
        Ok(())
    }

    /// All parameters of agent `agent`'s online actor and first critic.
    pub(crate) fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let mut actors = group.nets.actors.to_flats(&group.actor_layout)?;
        let mut critics = group.nets.critics.nets[0].to_flats(&group.critic_layout)?;
        Ok((actors.swap_remove(k), critics.swap_remove(k)))
    }

    /// `Q_i(x, g, a)` of agent `agent`'s first online critic for raw rows.
    pub(crate) fn q_values(
        &self,
        agent: usize,
        obs: &[f32],
        goals: &[f32],
        actions: &[f32],
        n: usize,
    ) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        if !matches!(self.groups[g].critic_view, CriticInput::Global) {
            return Err(NnError::InvalidConfig {
                key: "q_values",
                reason: format!("agent {agent}'s critic does not see the global rows this reads"),
            });
        }
        let spec = self.layout.spec();
        check_values(|| "q_values obs".into(), obs, n * spec.obs_dim)?;
        check_values(|| "q_values goals".into(), goals, n * spec.goal_dim)?;
        check_values(|| "q_values actions".into(), actions, n * spec.action_dim)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        let (od, gd, ad) = (spec.obs_dim, spec.goal_dim, self.perm.len());
        let mut og = Vec::with_capacity(n * (od + gd));
        for r in 0..n {
            og.extend_from_slice(&obs[r * od..(r + 1) * od]);
            og.extend_from_slice(&goals[r * gd..(r + 1) * gd]);
        }
        self.critic_norm.normalize(&mut og);
        let mut input = Vec::with_capacity(n * (od + gd + ad));
        for r in 0..n {
            input.extend_from_slice(&og[r * (od + gd)..(r + 1) * (od + gd)]);
            input.extend(self.perm.iter().map(|&s| actions[r * ad + s]));
        }
        let x = matrix(input, n, od + gd + ad, &self.device).unsqueeze_dim::<3>(0);
        let q = self.groups[g].nets.critics.nets[0].valid().forward(x);
        // One row for all agents when they share the whole critic.
        let row = if q.dims()[0] == 1 { 0 } else { k };
        let q = q.narrow(0, row, 1).reshape([n]);
        to_vec1(q, "q values")
    }

    /// Agent `i`'s first critic's trunk, flattened.
    pub(crate) fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let flats = group.nets.critics.nets[0].to_flats(&group.critic_layout)?;
        Ok(flats[k][group.critic_layout.shapes[k].trunk()].to_vec())
    }
}
