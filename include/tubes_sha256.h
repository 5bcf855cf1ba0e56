/* SHA-256 (FIPS 180-4) of a file's bytes, for the model cache's trust check (src/io/tubes_expr.c,
 * docs/cluster.md "The model cache"). src/io/tubes_sha256.c; no state outside the context. */
#ifndef TUBES_SHA256_H
#define TUBES_SHA256_H
#include <stddef.h>
#include <stdint.h>
#ifdef __cplusplus
extern "C" {
#endif
typedef struct {
  uint32_t h[8];          /* the running hash */
  uint64_t bytes;         /* message length so far */
  unsigned char buf[64];  /* the block being filled */
  size_t nbuf;
} tubes_sha256_t;
/* Start a hash. */
void tubes_sha256_init(tubes_sha256_t *c);
/* Add n bytes. */
void tubes_sha256_update(tubes_sha256_t *c, const void *data, size_t n);
/* The digest as 64 lowercase hex digits and a NUL (hex[65]). */
void tubes_sha256_hex(tubes_sha256_t *c, char hex[65]);
/* The digest of everything readable from fd (from its current offset) into hex; 0, or -1 with
 * errno set when a read failed. */
int tubes_sha256_fd(int fd, char hex[65]);
#ifdef __cplusplus
}
#endif
#endif
