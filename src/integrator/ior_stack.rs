//! The stack of media a ray is inside, for nested and intersecting
//! dielectrics. Each entry is a dielectric material and its priority. On a
//! dielectric surface: transmission into an object pushes it, transmission
//! out removes that object's entry (not necessarily the top: intersecting
//! volumes are left in any order), reflection and total internal reflection
//! leave the stack alone.
//!
//! Priorities (Schmidt & Budge 2002, "Simple Nested Dielectrics in Ray
//! Traced Images"): where volumes overlap, the one of HIGHER priority fills
//! the overlap. A surface met inside a medium of higher priority is a false
//! intersection: the ray goes straight on (entering or leaving that object
//! in the bookkeeping only). So water may overlap the inside of a glass's
//! walls (glass priority above water) and no coincident surfaces are needed.

/// Media a ray can be inside at once; deeper nesting is counted and ignored.
pub const CAPACITY: usize = 8;

/// One object the ray is inside: its material (a dielectric or an
/// interface) and that material's priority.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    pub material: u32,
    pub priority: i32,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct IorStack {
    entries: [Option<Entry>; CAPACITY],
    len: usize,
}

/// What a dielectric surface is to a ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Crossing {
    /// A surface inside a medium of higher priority: not really there.
    False,
    /// A real interface between `outside` (None: the ambient medium, n = 1)
    /// and `inside`, the material whose surface it is.
    Real { outside: Option<u32>, inside: u32 },
}

impl IorStack {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Enters a medium. False (and no change) when the stack is full.
    #[must_use]
    pub fn push(&mut self, medium: Entry) -> bool {
        if self.len == CAPACITY {
            return false;
        }
        self.entries[self.len] = Some(medium);
        self.len += 1;
        true
    }

    pub fn contains(&self, material: u32) -> bool {
        self.iter().any(|m| m.material == material)
    }

    /// Leaves a medium: removes its most recent entry, wherever it is.
    pub fn remove(&mut self, material: u32) -> bool {
        let Some(i) = (0..self.len)
            .rev()
            .find(|&i| self.entries[i].is_some_and(|m| m.material == material))
        else {
            return false;
        };
        for j in i..self.len - 1 {
            self.entries[j] = self.entries[j + 1];
        }
        self.len -= 1;
        self.entries[self.len] = None;
        true
    }

    fn iter(&self) -> impl DoubleEndedIterator<Item = Entry> + '_ {
        self.entries[..self.len]
            .iter()
            .map(|m| m.expect("entries below len are set"))
    }

    /// The medium the ray travels in: the highest priority; among equals,
    /// the most recently entered. None: the ambient medium.
    pub fn active(&self) -> Option<Entry> {
        self.active_without(None)
    }

    /// The participating medium a ray travels in: the active object's, or
    /// the world's when the stack is empty.
    #[inline]
    pub fn medium<'s>(&self, scene: &'s crate::scene::Scene) -> Option<&'s crate::medium::Medium> {
        scene.medium_inside(self.active().map(|e| e.material))
    }

    fn active_without(&self, skip: Option<u32>) -> Option<Entry> {
        let mut skipped = false;
        let mut best: Option<Entry> = None;
        for m in self.iter().rev() {
            if !skipped && Some(m.material) == skip {
                skipped = true;
                continue;
            }
            if best.is_none_or(|b| m.priority > b.priority) {
                best = Some(m);
            }
        }
        best
    }

    /// Classifies a hit on the surface of `medium`, `entering` its volume
    /// (against the surface normal) or leaving it.
    pub fn classify(&self, medium: Entry, entering: bool) -> Crossing {
        let active = self.active();
        if entering {
            if active.is_some_and(|a| a.priority > medium.priority) {
                return Crossing::False;
            }
            return Crossing::Real {
                outside: active.map(|a| a.material),
                inside: medium.material,
            };
        }
        if !self.contains(medium.material) {
            // Leaving a volume the ray was never seen to enter (the camera
            // starts inside it, or it is not closed): an interface with
            // whatever the ray is in.
            return Crossing::Real {
                outside: active.map(|a| a.material),
                inside: medium.material,
            };
        }
        match active {
            Some(a) if a.material != medium.material => Crossing::False,
            _ => Crossing::Real {
                outside: self
                    .active_without(Some(medium.material))
                    .map(|a| a.material),
                inside: medium.material,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GLASS: Entry = Entry {
        material: 1,
        priority: 2,
    };
    const WATER: Entry = Entry {
        material: 2,
        priority: 1,
    };
    const ICE: Entry = Entry {
        material: 3,
        priority: 3,
    };
    const LENS: Entry = Entry {
        material: 4,
        priority: 0,
    };

    #[test]
    fn the_four_cases_of_a_single_object() {
        let mut s = IorStack::default();
        // Entering from the ambient medium: a real interface; transmission pushes.
        assert_eq!(
            s.classify(LENS, true),
            Crossing::Real {
                outside: None,
                inside: 4
            }
        );
        assert!(s.push(LENS));
        // Reflection or TIR inside: the stack is unchanged, and the next hit
        // on the same surface leaves the lens towards the ambient medium.
        assert_eq!(
            s.classify(LENS, false),
            Crossing::Real {
                outside: None,
                inside: 4
            }
        );
        assert_eq!(s.len(), 1);
        // Transmission out removes it.
        assert!(s.remove(4));
        assert!(s.is_empty());
        // Reflection off the outside changes nothing.
        assert_eq!(
            s.classify(LENS, true),
            Crossing::Real {
                outside: None,
                inside: 4
            }
        );
    }

    #[test]
    fn nested_objects_see_their_neighbours() {
        // A lens (priority 0) inside water (priority 1).
        let mut s = IorStack::default();
        assert!(s.push(WATER));
        // Entering the lens from the water: the lens has lower priority, so
        // inside water it is a false intersection...
        assert_eq!(s.classify(LENS, true), Crossing::False);
        // ...while a lens of equal or higher priority is real, water outside.
        let lens_high = Entry {
            material: 4,
            priority: 5,
        };
        assert_eq!(
            s.classify(lens_high, true),
            Crossing::Real {
                outside: Some(2),
                inside: 4
            }
        );
        assert!(s.push(lens_high));
        assert_eq!(
            s.classify(lens_high, false),
            Crossing::Real {
                outside: Some(2),
                inside: 4
            }
        );
    }

    #[test]
    fn intersecting_volumes_exit_out_of_order() {
        let a = Entry {
            material: 10,
            priority: 0,
        };
        let b = Entry {
            material: 11,
            priority: 0,
        };
        let mut s = IorStack::default();
        assert!(s.push(a));
        assert_eq!(
            s.classify(b, true),
            Crossing::Real {
                outside: Some(10),
                inside: 11
            }
        );
        assert!(s.push(b));
        // Leaving A while inside B (the overlap belongs to B, entered last):
        // a false intersection, and A leaves the stack from below B.
        assert_eq!(s.classify(a, false), Crossing::False);
        assert!(s.remove(10));
        assert_eq!(s.active(), Some(b));
        assert_eq!(
            s.classify(b, false),
            Crossing::Real {
                outside: None,
                inside: 11
            }
        );
    }

    #[test]
    fn glass_of_water_with_ice_priorities() {
        // Camera ray: into the glass wall, out of its inner surface (which
        // the water overlaps), through water, into ice.
        let mut s = IorStack::default();
        assert_eq!(
            s.classify(GLASS, true),
            Crossing::Real {
                outside: None,
                inside: 1
            }
        );
        assert!(s.push(GLASS));
        // The water's outer surface lies inside the glass wall: false.
        assert_eq!(s.classify(WATER, true), Crossing::False);
        assert!(s.push(WATER));
        // Leaving the glass's inner wall: a real glass → water interface.
        assert_eq!(
            s.classify(GLASS, false),
            Crossing::Real {
                outside: Some(2),
                inside: 1
            }
        );
        assert!(s.remove(1));
        // Ice in water: real, water outside.
        assert_eq!(
            s.classify(ICE, true),
            Crossing::Real {
                outside: Some(2),
                inside: 3
            }
        );
        assert!(s.push(ICE));
        assert_eq!(
            s.classify(ICE, false),
            Crossing::Real {
                outside: Some(2),
                inside: 3
            }
        );
        assert!(s.remove(3));
        // Ice poking out of the water surface: leaving the water inside the
        // ice is false; leaving the ice then meets air.
        assert!(s.push(ICE));
        assert_eq!(s.classify(WATER, false), Crossing::False);
        assert!(s.remove(2));
        assert_eq!(
            s.classify(ICE, false),
            Crossing::Real {
                outside: None,
                inside: 3
            }
        );
    }

    #[test]
    fn overflow_is_refused_not_a_panic() {
        let mut s = IorStack::default();
        for i in 0..CAPACITY as u32 {
            assert!(s.push(Entry {
                material: i,
                priority: 0
            }));
        }
        assert!(!s.push(Entry {
            material: 99,
            priority: 0
        }));
        assert_eq!(s.len(), CAPACITY);
        assert!(!s.remove(99));
        assert!(s.remove(3));
        assert_eq!(s.len(), CAPACITY - 1);
    }
}
