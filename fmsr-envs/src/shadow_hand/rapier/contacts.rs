//! Contact filtering as MuJoCo's `(contype1 & conaffinity2) || (contype2 & conaffinity1)`:
//! the distinct `(contype, conaffinity)` classes of the model's geoms get one
//! collision-group bit each, and each class's filter holds the classes it
//! collides with under MuJoCo's rule. A symmetric relation over at most 31
//! classes is encoded exactly by rapier's AND test, so no physics hook runs for
//! them (contact recycling stays on). The 19 `<contact><pair>`s of `shared.xml`
//! (finger-finger and finger-thumb, which MuJoCo collides regardless of
//! `contype`): their colliders share one more group bit, and a physics hook on
//! those colliders drops the pairs that only that bit admitted and are not listed.

use std::collections::HashMap;

use rapier3d::math::{Real, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::Model;
use rapier3d_mjcf::{MjcfRobot, MjcfRobotHandles};

use crate::error::EnvError;

/// A collider of the model: (body index, collider index in body).
pub(super) type ColliderKey = (usize, usize);

/// The collision groups of the model's colliders by their MuJoCo class; the
/// ground plane's (MuJoCo's default plane geom) at `(usize::MAX, 0)`.
pub(super) fn collision_groups(
    robot: &MjcfRobot,
    model: &Model,
) -> Result<HashMap<ColliderKey, InteractionGroups>, EnvError> {
    let mut geom_classes = HashMap::new();
    for entry in &model.bodies {
        for g in &entry.body.geoms {
            if let Some(n) = &g.name {
                geom_classes.insert(n.clone(), (g.contype, g.conaffinity));
            }
        }
    }
    let mut classes: Vec<(u32, u32)> = Vec::new();
    let mut collider_class = HashMap::new();
    for (geom, &(body, col)) in &robot.geom_name_to_collider {
        let Some(&(ct, ca)) = geom_classes.get(geom) else { continue };
        let k = classes.iter().position(|&c| c == (ct, ca)).unwrap_or_else(|| {
            classes.push((ct, ca));
            classes.len() - 1
        });
        collider_class.insert((body, col), k);
    }
    // The ground we add is MuJoCo's default plane geom: contype = conaffinity = 1.
    let ground_class = classes.iter().position(|&c| c == (1, 1)).unwrap_or_else(|| {
        classes.push((1, 1));
        classes.len() - 1
    });
    if classes.len() > 31 {
        return Err(EnvError::Model(format!("{} contact classes, at most 31 supported", classes.len())));
    }
    let collide = |a: (u32, u32), b: (u32, u32)| (a.0 & b.1) != 0 || (b.0 & a.1) != 0;
    let class_groups: Vec<InteractionGroups> = classes
        .iter()
        .map(|&a| {
            let member = 1u32 << classes.iter().position(|&c| c == a).unwrap_or(0);
            let filter =
                classes.iter().enumerate().filter(|&(_, &b)| collide(a, b)).fold(0u32, |acc, (j, _)| acc | (1 << j));
            InteractionGroups::new(Group::from(member), Group::from(filter), InteractionTestMode::And)
        })
        .collect();
    let mut groups: HashMap<(usize, usize), InteractionGroups> =
        collider_class.into_iter().map(|(key, k)| (key, class_groups[k])).collect();
    groups.insert((usize::MAX, 0), class_groups[ground_class]);
    Ok(groups)
}

/// The `<contact><pair>` geoms, as colliders.
pub(super) fn contact_pairs(robot: &MjcfRobot) -> Result<Vec<(ColliderKey, ColliderKey)>, EnvError> {
    let pairs = robot
        .contact_pairs
        .iter()
        .filter_map(|p| {
            let a = robot.geom_name_to_collider.get(&p.geom1)?;
            let b = robot.geom_name_to_collider.get(&p.geom2)?;
            Some((*a, *b))
        })
        .collect::<Vec<_>>();
    if pairs.len() != robot.contact_pairs.len() {
        return Err(EnvError::Model("a <contact><pair> names a geom without a collider".into()));
    }
    Ok(pairs)
}

/// Gives every inserted collider its collision groups.
pub(super) fn apply_groups(
    world: &mut PhysicsWorld,
    handles: &MjcfRobotHandles<Option<MultibodyJointHandle>>,
    groups: &HashMap<ColliderKey, InteractionGroups>,
) {
    for (bi, b) in handles.bodies.iter().enumerate() {
        let Some(b) = b else { continue };
        for (ci, c) in b.colliders.iter().enumerate() {
            if let (Some(g), Some(col)) = (groups.get(&(bi, ci)), world.colliders.get_mut(c.handle)) {
                col.set_collision_groups(*g);
            }
        }
    }
}

/// `<contact><pair>`: the pairs' colliders share [`PAIR_BIT`], and the hook
/// returned keeps, among the pairs that bit lets through, only the listed ones.
pub(super) fn install_pairs(
    world: &mut PhysicsWorld,
    pairs: &[(ColliderKey, ColliderKey)],
    collider_of: impl Fn(ColliderKey) -> Option<ColliderHandle>,
) -> PairHooks {
    let mut hooks = PairHooks::default();
    for &(a, b) in pairs {
        let (Some(a), Some(b)) = (collider_of(a), collider_of(b)) else { continue };
        hooks.pairs.insert((a, b));
        hooks.pairs.insert((b, a));
        for h in [a, b] {
            if let Some(col) = world.colliders.get_mut(h) {
                let g = col.collision_groups();
                col.set_collision_groups(InteractionGroups::new(
                    g.memberships | PAIR_BIT,
                    g.filter | PAIR_BIT,
                    InteractionTestMode::And,
                ));
                col.set_active_hooks(col.active_hooks() | ActiveHooks::FILTER_CONTACT_PAIRS);
            }
        }
    }
    hooks
}

/// Calls `f(normal, point, normal impulse)` for every point of `pair` with a
/// positive normal impulse: the manifold's normal outward from collider 1 and the
/// midpoint of the two surfaces' points, in the world frame.
pub(super) fn for_each_point(colliders: &ColliderSet, pair: &ContactPair, mut f: impl FnMut(Vector, Vector, Real)) {
    let PairContacts::Rigid(rigid) = &pair.contacts else { return };
    let (Some(c1), Some(c2)) = (colliders.get(pair.collider1), colliders.get(pair.collider2)) else { return };
    for m in &rigid.manifolds {
        // `local_n1`: the contact normal, outward from collider 1, in its frame.
        let n1 = c1.position().rotation * m.local_n1;
        for pt in m.points.iter().filter(|pt| pt.data.impulse > 0.0) {
            let p1 = c1.position().transform_point(pt.local_p1);
            let p2 = c2.position().transform_point(pt.local_p2);
            f(n1, (p1 + p2) * 0.5, pt.data.impulse);
        }
    }
}

/// The collision-group bit shared by the colliders of `<contact><pair>` elements.
const PAIR_BIT: Group = Group::GROUP_32;

/// Keeps the explicit `<contact><pair>`s among the pairs [`PAIR_BIT`] admits.
#[derive(Debug, Default, Clone)]
pub(super) struct PairHooks {
    pairs: std::collections::HashSet<(ColliderHandle, ColliderHandle)>,
}

impl PhysicsHooks for PairHooks {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        if self.pairs.contains(&(context.collider1, context.collider2)) {
            return Some(SolverFlags::default());
        }
        let strip = |h: ColliderHandle| {
            context.colliders.get(h).map(|c| {
                let g = c.collision_groups();
                InteractionGroups::new(g.memberships - PAIR_BIT, g.filter - PAIR_BIT, InteractionTestMode::And)
            })
        };
        match (strip(context.collider1), strip(context.collider2)) {
            (Some(a), Some(b)) if a.test(b) => Some(SolverFlags::default()),
            _ => None,
        }
    }
}
