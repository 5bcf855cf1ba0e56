/* The one writer of a scene's result record (src/io/tubes_record_write.c; include/tubes.h, "Scenes and
 * their records"). */
#ifndef TUBES_RECORD_H
#define TUBES_RECORD_H
#include <hdf5.h>
#ifdef __cplusplus
extern "C" {
#endif
/* Record h's console lines printed in order (stdout, stderr), its datasets and attributes written
 * under file (groups made where missing), the record freed. Returns its exit code (the worst
 * verdict's, 0 none), or EXIT_IO when a write failed. */
int record_emit(hid_t file, int h);
#ifdef __cplusplus
}
#endif
#endif
