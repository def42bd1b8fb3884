/* serial2pty: LiteX simulation module connecting the SoC's stream UART (the "serial" pads
 * of RS232PHYModel) to a new pseudo-terminal, so that a host program opens the simulated
 * board's UART like a USB-serial adapter.
 *
 * At start it opens a pty pair in raw mode and prints "serial2pty: /dev/pts/N" on stdout.
 * It keeps the pty's slave side open itself, so that output written before a client opens
 * it waits in the tty buffer instead of being lost.
 *
 * Flow control both ways, unlike LiteX's serial2tcp (which drops bytes with no client and
 * overruns its 2 KiB receive buffer when the host writes faster than the SoC reads):
 *   - SoC -> host: bytes go to `out`; when `out` is full (the pty does not take more),
 *     `source_ready` stays low and the SoC's UART waits;
 *   - host -> SoC: the pty is only read into the free part of `in`; `sink_valid` offers the
 *     head byte until the SoC takes it.
 * The pty is polled every POLL_CYCLES clock cycles.
 *
 * Arguments (sim_config.js, optional): {"link": "/path"} also makes a symlink to the pty.
 */
/* posix_openpt, grantpt, unlockpt, ptsname, cfmakeraw. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include <json-c/json.h>

#include "error.h"
#include "modules.h"

#define BUF_SIZE 4096
#define POLL_CYCLES 256

struct session_s {
  /* Pads: tx = SoC -> host (the PHY's sink side), rx = host -> SoC. */
  char *tx;
  char *tx_valid;
  char *tx_ready;
  char *rx;
  char *rx_valid;
  char *rx_ready;
  char *sys_clk;
  clk_edge_state_t edge;
  int master;
  int slave_hold;
  uint8_t in[BUF_SIZE]; /* from the host, not yet taken by the SoC */
  size_t in_head, in_len;
  uint8_t out[BUF_SIZE]; /* from the SoC, not yet written to the pty */
  size_t out_len;
  uint64_t cycle, next_poll;
};

static int serial2pty_start(void *base) {
  (void)base;
  return RC_OK;
}

static char *optional_arg(const char *args, const char *key) {
  json_object *root, *obj;
  char *value = NULL;
  if (!args)
    return NULL;
  root = json_tokener_parse(args);
  if (root && json_object_object_get_ex(root, key, &obj))
    value = strdup(json_object_get_string(obj));
  if (root)
    json_object_put(root);
  return value;
}

static int open_pty(struct session_s *s, const char *link) {
  struct termios t;
  const char *name;

  s->master = posix_openpt(O_RDWR | O_NOCTTY);
  if (s->master < 0 || grantpt(s->master) != 0 || unlockpt(s->master) != 0) {
    eprintf("serial2pty: cannot open a pseudo-terminal: %s\n", strerror(errno));
    return RC_ERROR;
  }
  name = ptsname(s->master);
  if (!name) {
    eprintf("serial2pty: ptsname: %s\n", strerror(errno));
    return RC_ERROR;
  }
  s->slave_hold = open(name, O_RDWR | O_NOCTTY);
  if (s->slave_hold < 0 || tcgetattr(s->slave_hold, &t) != 0) {
    eprintf("serial2pty: opening %s: %s\n", name, strerror(errno));
    return RC_ERROR;
  }
  /* Raw until a client configures it: no echo, no CR/LF translation of the binary link. */
  cfmakeraw(&t);
  tcsetattr(s->slave_hold, TCSANOW, &t);
  fcntl(s->master, F_SETFL, fcntl(s->master, F_GETFL) | O_NONBLOCK);
  if (link) {
    unlink(link);
    if (symlink(name, link) != 0) {
      eprintf("serial2pty: symlink %s -> %s: %s\n", link, name, strerror(errno));
      return RC_ERROR;
    }
  }
  printf("serial2pty: %s\n", name);
  fflush(stdout);
  return RC_OK;
}

static int serial2pty_new(void **sess, char *args) {
  struct session_s *s;
  char *link;
  int ret;

  if (!sess)
    return RC_INVARG;
  s = calloc(1, sizeof(*s));
  if (!s)
    return RC_NOENMEM;
  s->master = s->slave_hold = -1;
  link = optional_arg(args, "link");
  ret = open_pty(s, link);
  free(link);
  *sess = s;
  return ret;
}

static void pads_get(struct pad_s *pads, const char *name, char **signal) {
  for (int i = 0; pads[i].name; i++) {
    if (!strcmp(pads[i].name, name)) {
      *signal = (char *)pads[i].signal;
      return;
    }
  }
}

static int serial2pty_add_pads(void *sess, struct pad_list_s *plist) {
  struct session_s *s = sess;
  if (!s || !plist)
    return RC_INVARG;
  if (!strcmp(plist->name, "serial")) {
    pads_get(plist->pads, "source_data", &s->tx);
    pads_get(plist->pads, "source_valid", &s->tx_valid);
    pads_get(plist->pads, "source_ready", &s->tx_ready);
    pads_get(plist->pads, "sink_data", &s->rx);
    pads_get(plist->pads, "sink_valid", &s->rx_valid);
    pads_get(plist->pads, "sink_ready", &s->rx_ready);
  }
  if (!strcmp(plist->name, "sys_clk"))
    pads_get(plist->pads, "sys_clk", &s->sys_clk);
  return RC_OK;
}

/* Moves bytes between the buffers and the pty without blocking. */
static void poll_pty(struct session_s *s) {
  if (s->out_len) {
    ssize_t n = write(s->master, s->out, s->out_len);
    if (n > 0) {
      memmove(s->out, s->out + n, s->out_len - (size_t)n);
      s->out_len -= (size_t)n;
    }
  }
  if (s->in_len == 0)
    s->in_head = 0;
  if (s->in_head + s->in_len < BUF_SIZE) {
    ssize_t n = read(s->master, s->in + s->in_head + s->in_len, BUF_SIZE - s->in_head - s->in_len);
    if (n > 0)
      s->in_len += (size_t)n;
  }
}

static int serial2pty_tick(void *sess, uint64_t time_ps) {
  struct session_s *s = sess;
  (void)time_ps;
  if (!clk_pos_edge(&s->edge, *s->sys_clk))
    return RC_OK;
  s->cycle++;

  /* The pads were just updated by this edge; what we set now holds at the next one (the
   * UART's valid and ready do not depend on ours combinationally: FIFO flags). */
  if (s->cycle >= s->next_poll) {
    poll_pty(s);
    s->next_poll = s->cycle + POLL_CYCLES;
  }

  /* SoC -> host: accept the byte on offer at the next edge if there is room for it. */
  *s->tx_ready = s->out_len < BUF_SIZE;
  if (*s->tx_valid && *s->tx_ready)
    s->out[s->out_len++] = (uint8_t)*s->tx;

  /* Host -> SoC: offer the head byte; it is taken at the next edge when ready is high. */
  *s->rx_valid = 0;
  if (s->in_len) {
    *s->rx = (char)s->in[s->in_head];
    *s->rx_valid = 1;
    if (*s->rx_ready) {
      s->in_head++;
      s->in_len--;
    }
  }
  return RC_OK;
}

static int serial2pty_close(void *sess) {
  struct session_s *s = sess;
  if (!s)
    return RC_OK;
  if (s->master >= 0) {
    /* Deliver what the SoC sent last (best effort: the pty may be full). */
    ssize_t n = s->out_len ? write(s->master, s->out, s->out_len) : 0;
    (void)n;
    close(s->master);
  }
  if (s->slave_hold >= 0)
    close(s->slave_hold);
  free(s);
  return RC_OK;
}

static struct ext_module_s ext_mod = {
    "serial2pty", serial2pty_start, serial2pty_new, serial2pty_add_pads, serial2pty_close, serial2pty_tick,
};

int litex_sim_ext_module_init(int (*register_module)(struct ext_module_s *)) {
  return register_module(&ext_mod);
}
