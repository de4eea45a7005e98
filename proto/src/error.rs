//! The protocol crate's one error type: what can be wrong with bytes that
//! arrive from the wire.

/// Why something from the wire was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum Error {
    // Blob chunks.
    /// No chunk arrived.
    #[error("no chunk arrived")]
    Empty,
    /// A chunk names another blob.
    #[error("a chunk names another blob")]
    OtherBlob,
    /// Chunks disagree on the total size.
    #[error("chunks disagree on the total size")]
    SizeChanged,
    /// The declared size is over the limit.
    #[error("a blob of {0} bytes is over the {1}-byte limit")]
    TooLarge(u64, u64),
    /// A chunk is not where the previous one ended.
    #[error("chunk at offset {got} where {want} was expected")]
    OutOfOrder {
        /// Offset received.
        got: u64,
        /// Offset expected.
        want: u64,
    },
    /// More bytes than declared.
    #[error("more bytes than the total size")]
    TooMany,
    /// Fewer bytes than declared.
    #[error("{got} of {want} bytes arrived")]
    Incomplete {
        /// Bytes received.
        got: u64,
        /// Bytes declared.
        want: u64,
    },
    // Scene manifests.
    /// The bytes are not a manifest of this protocol version.
    #[error("malformed scene manifest: {0}")]
    Malformed(String),
    /// An asset the manifest names is missing or does not match its hash.
    #[error("scene asset {key} is missing or corrupt")]
    Asset {
        /// The asset's key in the scene.
        key: String,
    },
    // Film tiles.
    /// The bounds are inverted or absurdly large.
    #[error("film tile bounds ({x0},{y0})-({x1},{y1}) are invalid")]
    BadBounds {
        /// Left.
        x0: i32,
        /// Top.
        y0: i32,
        /// Right.
        x1: i32,
        /// Bottom.
        y1: i32,
    },
    /// The byte count does not match the bounds.
    #[error("film tile holds {got} bytes where its bounds need {want}")]
    WrongSize {
        /// Bytes received.
        got: usize,
        /// Bytes the bounds call for.
        want: usize,
    },
    // Images sent as chunks of rows.
    /// An image chunk that does not continue the image.
    #[error("image chunk at row {row} ({bytes} bytes) does not fit a {width}×{height} image")]
    ImageChunk {
        /// Its first row.
        row: u32,
        /// Its pixel bytes.
        bytes: usize,
        /// The image's width.
        width: u32,
        /// The image's height.
        height: u32,
    },
    /// A preview piece outside its image, or whose bytes do not fit it.
    #[error("preview piece [{x0}, {x1}) × [{y0}, {y1}) does not fit a {width}×{height} image")]
    PreviewPiece {
        /// Its bounds.
        x0: i32,
        /// Its bounds.
        y0: i32,
        /// Its bounds.
        x1: i32,
        /// Its bounds.
        y1: i32,
        /// The image's width.
        width: u32,
        /// The image's height.
        height: u32,
    },
}

/// Results of decoding.
pub type Result<T> = std::result::Result<T, Error>;
