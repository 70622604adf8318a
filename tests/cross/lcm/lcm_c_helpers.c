/* Access to lcm-gen's code for types whose C layout C++ cannot share: an empty struct has
 * size 0 in GNU C but 1 in C++, so xtest_holder_t is built and read here, in C. */
#include <stdint.h>
#include <string.h>

#include "xtest_holder_t.h"

int lcm_cross_holder_encode(uint8_t *buf, int maxlen, int8_t tag)
{
    xtest_holder_t holder;
    memset(&holder, 0, sizeof holder);
    holder.tag = tag;
    return xtest_holder_t_encode(buf, 0, maxlen, &holder);
}

int lcm_cross_holder_decode(const uint8_t *buf, int len, int8_t *tag)
{
    xtest_holder_t holder;
    memset(&holder, 0, sizeof holder);
    int status = xtest_holder_t_decode(buf, 0, len, &holder);
    if (status >= 0) {
        *tag = holder.tag;
        xtest_holder_t_decode_cleanup(&holder);
    }
    return status;
}

int64_t lcm_cross_holder_hash(void) { return __xtest_holder_t_get_hash(); }
int64_t lcm_cross_empty_hash(void) { return __xtest_empty_t_get_hash(); }
