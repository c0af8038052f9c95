/work/main/fuzz/target/x86_64-unknown-linux-gnu/release/deps/rawpointer-94f536efe8d850dc.d: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/rawpointer-0.2.1/src/lib.rs

/work/main/fuzz/target/x86_64-unknown-linux-gnu/release/deps/librawpointer-94f536efe8d850dc.rlib: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/rawpointer-0.2.1/src/lib.rs

/work/main/fuzz/target/x86_64-unknown-linux-gnu/release/deps/librawpointer-94f536efe8d850dc.rmeta: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/rawpointer-0.2.1/src/lib.rs

/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/rawpointer-0.2.1/src/lib.rs:
