//! Which instance owns a drive when several share a fleet (see
//! `docs/decisions/serve-shared-subscriptions.md`): the instances announce themselves on
//! retained presence topics (cleared by their last will), and each drive goes to the live
//! instance of highest rendezvous weight (Thaler & Ravishankar 1998, "Using name-based mappings
//! to increase hit rates"), so a joining or leaving instance moves only its share of the drives.

use std::collections::BTreeSet;

/// Presence topic of instance `id`: `<prefix>/_serve/instances/<id>`.
pub(crate) fn presence_topic(prefix: &str, id: &str) -> String {
    format!("{prefix}/_serve/instances/{id}")
}

/// Filter of every instance's presence topic.
pub(crate) fn presence_filter(prefix: &str) -> String {
    format!("{prefix}/_serve/instances/+")
}

/// Topic on which instance `id` receives the batches other instances pass on to it.
pub(crate) fn forward_topic(prefix: &str, id: &str, drive: &str) -> String {
    format!("{prefix}/_serve/to/{id}/{drive}/readings")
}

/// The instances alive as this one sees them (itself among them until it leaves).
#[derive(Debug, Clone)]
pub(crate) struct Fleet {
    me: String,
    members: BTreeSet<String>,
    leaving: bool,
}

impl Fleet {
    pub(crate) fn new(me: &str) -> Self {
        Fleet {
            me: me.to_string(),
            members: BTreeSet::from([me.to_string()]),
            leaving: false,
        }
    }

    /// This instance leaves: from now on its drives belong to the others.
    pub(crate) fn leave(&mut self) {
        self.leaving = true;
        self.members.remove(&self.me);
    }

    pub(crate) fn leaving(&self) -> bool {
        self.leaving
    }

    pub(crate) fn me(&self) -> &str {
        &self.me
    }

    pub(crate) fn len(&self) -> usize {
        self.members.len()
    }

    /// A presence message: a non-empty payload announces `id`, an empty one (its last will or
    /// its goodbye) removes it. Only [`Fleet::leave`] changes this instance's own membership.
    pub(crate) fn presence(&mut self, id: &str, payload: &[u8]) {
        if id == self.me {
            return;
        }
        if payload.is_empty() {
            self.members.remove(id);
        } else {
            self.members.insert(id.to_string());
        }
    }

    /// The instance owning `drive`: the member of highest weight `hash(member, drive)` (none
    /// when this instance leaves and sees no other).
    pub(crate) fn owner(&self, drive: &str) -> Option<&str> {
        self.members
            .iter()
            .max_by_key(|m| (weight(m, drive), m.as_str()))
            .map(String::as_str)
    }
}

/// FNV-1a, 64 bit (Fowler, Noll, Vo; IETF draft-eastlake-fnv): stable across builds and
/// platforms, so every instance computes the same weights.
fn weight(member: &str, drive: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in member.bytes().chain([0u8]).chain(drive.bytes()) {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    // A final avalanche (the SplitMix64 finaliser, Steele, Lea & Flood 2014) spreads FNV's
    // weak high bits, so close names do not favour one member.
    h ^= h >> 30;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^ (h >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drives() -> Vec<String> {
        (0..200).map(|i| format!("drive-{i}")).collect()
    }

    #[test]
    fn every_instance_agrees_and_the_split_is_even() {
        let mut a = Fleet::new("a");
        let mut b = Fleet::new("b");
        a.presence("b", b"online");
        b.presence("a", b"online");
        let at_a = drives().iter().filter(|d| a.owner(d) == Some("a")).count();
        assert!(drives().iter().all(|d| a.owner(d) == b.owner(d)));
        assert!((70..=130).contains(&at_a), "a owns {at_a} of 200");
    }

    #[test]
    fn a_joining_instance_takes_drives_only_from_the_others_to_itself() {
        let mut two = Fleet::new("a");
        two.presence("b", b"1");
        let mut three = two.clone();
        three.presence("c", b"1");
        for d in drives() {
            let (before, after) = (two.owner(&d), three.owner(&d));
            assert!(
                before == after || after == Some("c"),
                "{d}: {before:?} -> {after:?}"
            );
        }
        three.presence("c", b"");
        assert!(drives().iter().all(|d| two.owner(d) == three.owner(d)));
        three.presence("a", b"");
        assert_eq!(
            three.len(),
            2,
            "a presence message never removes this instance"
        );
        three.leave();
        assert!(drives().iter().all(|d| three.owner(d) == Some("b")));
        let mut alone = Fleet::new("a");
        alone.leave();
        assert_eq!(alone.owner("drive-1"), None);
    }
}
