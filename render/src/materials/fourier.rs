//! `Material "fourier"` (pbrt-v3 `FourierMaterial`): a tabulated BSDF read
//! from a layerlab `SCATFUN` file, one table per file however many
//! materials (or shapes overriding them) name it.

use super::create::MaterialParams;
use crate::bxdf::{Bsdf, BxDF, FourierBsdf, FourierTable, TransportMode};
use crate::interaction::SurfaceInteraction;
use crate::textures::TexInput;
use farm_common::scene::{FileLoc, Warning};
use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// A tabulated BSDF.
#[derive(Clone, Debug, PartialEq)]
pub struct Fourier {
    /// The table; `None` when the file could not be read, which pbrt-v3
    /// reports and renders as black.
    pub table: Option<Arc<FourierTable>>,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Fourier {
    /// The BSDF at `si`: the table's lobe, if it was read.
    pub fn bsdf(&self, si: &SurfaceInteraction, mode: TransportMode) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        if let Some(table) = &self.table {
            bsdf.add(BxDF::Fourier(FourierBsdf { table, mode }));
        }
        bsdf
    }

    /// A `Material "fourier"` with pbrt-v3's parameters (`CreateFourierMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        let file = m.string("bsdffile", "");
        let table = m.files.fourier(&file, m.loc(), w);
        Fourier { table, bump: m.bump }
    }
}

/// The files materials read, from the scene's assets (the parser loaded
/// them), and the tables already made from them (pbrt-v3's `loadedBSDFs`).
#[derive(Debug)]
pub struct MaterialFiles<'a> {
    assets: &'a BTreeMap<String, Vec<u8>>,
    tables: RefCell<HashMap<String, Option<Arc<FourierTable>>>>,
}

impl MaterialFiles<'static> {
    /// No files: for materials built without a scene.
    pub fn none() -> Self {
        static EMPTY: BTreeMap<String, Vec<u8>> = BTreeMap::new();
        MaterialFiles::new(&EMPTY)
    }
}

impl<'a> MaterialFiles<'a> {
    /// Files from a scene's assets.
    pub fn new(assets: &'a BTreeMap<String, Vec<u8>>) -> Self {
        MaterialFiles { assets, tables: RefCell::default() }
    }

    /// The table in `file`, read once; a file that is missing or not a
    /// table pbrt-v3 reads draws pbrt-v3's message, once.
    fn fourier(
        &self,
        file: &str,
        loc: &FileLoc,
        w: &mut Vec<Warning>,
    ) -> Option<Arc<FourierTable>> {
        if let Some(t) = self.tables.borrow().get(file) {
            return t.clone();
        }
        let table = match self.assets.get(file) {
            None => {
                w.push(Warning::at(
                    loc,
                    format!("Unable to open tabulated BSDF file \"{file}\"; the material is black"),
                ));
                None
            }
            Some(bytes) => match FourierTable::read(bytes) {
                Ok(t) => Some(Arc::new(t)),
                Err(e) => {
                    w.push(Warning::at(
                        loc,
                        format!(
                            "Tabulated BSDF file \"{file}\" has an incompatible file format or version ({e}); the material is black"
                        ),
                    ));
                    None
                }
            },
        };
        self.tables.borrow_mut().insert(file.to_string(), table.clone());
        table
    }
}
