// A fixture of tests/arch: every citation below is broken in its own way.
// docs/a.md §1 exists; docs/a.md §2 does not.
// docs/missing.md is not a file.
// DESIGN §3 names a document outside the repository.
int cites() {
    return 0;
}
