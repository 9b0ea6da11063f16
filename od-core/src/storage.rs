//! Parameter storage: the 1010h/1011h groups as a versioned, checksummed image on flash pages,
//! updated so that a power cut at any instant leaves the old or the new image, never a mix.
