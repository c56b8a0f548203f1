// The translation unit whose compile produces the precompiled header every
// test program reuses (cmake/precompiled_headers.cmake); it has no code.
