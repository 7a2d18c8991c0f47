//! Benchmarks of ferrobot (see benches/benches).
