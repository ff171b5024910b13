/* SPDX-License-Identifier: MIT
 * test_docs.c -- the README's parameter table is the library's table
 * (pkss_param_at), row for row: a change to a range, default or doc that
 * is not carried into README.md fails here, and the failure prints the
 * block to paste between the params markers.
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_docs";

#ifndef PKSS_SOURCE_DIR
#error "PKSS_SOURCE_DIR must name the repository root"
#endif

/* The name of value v in a '|'-separated choices list. */
static void choice_name(const char *choices, int v, char *out, size_t size)
{
    const char *p = choices;
    for (int i = 0; i < v && p; ++i) {
        p = strchr(p, '|');
        if (p)
            ++p;
    }
    size_t len = p ? strcspn(p, "|") : 0;
    snprintf(out, size, "%.*s", (int)len, p ? p : "");
}

/* The README row of one parameter. */
static void row(const pkss_param_info *in, char *out, size_t size)
{
    char def[64], range[96];
    if (in->type == PKSS_TYPE_STRING) {
        snprintf(def, sizeof def, "-");
        snprintf(range, sizeof range, "string");
    } else if (in->type == PKSS_TYPE_SWITCH || in->type == PKSS_TYPE_CHOICE) {
        choice_name(in->choices, (int)in->default_value, def, sizeof def);
        /* the values, but the "default" that 0 names for switches */
        const char *rest = strncmp(in->choices, "default|", 8) == 0 ? in->choices + 8
                                                                   : in->choices;
        snprintf(range, sizeof range, "%s", rest);
        for (char *c = range; *c; ++c)
            if (*c == '|')
                *c = '/';
    } else {
        snprintf(def, sizeof def, "%.15g", in->default_value);
        snprintf(range, sizeof range, "%.15g - %.15g%s%s", in->lower, in->upper,
                 in->constraint[0] ? ", " : "", in->constraint);
    }
    snprintf(out, size, "| `%s` | %s | %s | %s | %s |", in->name, def, range,
             in->unit[0] ? in->unit : "-", in->doc);
}

static char *read_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *s = malloc((size_t)n + 1);
    if (s && fread(s, 1, (size_t)n, f) == (size_t)n)
        s[n] = '\0';
    fclose(f);
    return s;
}

static void test_readme_parameter_table(void **state)
{
    (void)state;
    char expected[16384] = "| parameter | default | range | unit | meaning |\n|---|---|---|---|---|\n";
    for (size_t i = 0; i < pkss_param_count(); ++i) {
        pkss_param_info info;
        pkss_param_info_init(&info, sizeof info);
        assert_int_equal(pkss_param_at(i, &info), PKSS_OK);
        char line[1024];
        row(&info, line, sizeof line);
        strncat(expected, line, sizeof expected - strlen(expected) - 2);
        strcat(expected, "\n");
    }
    char *readme = read_file(PKSS_SOURCE_DIR "/README.md");
    assert_non_null(readme);
    const char *begin = strstr(readme, "<!-- params:begin -->\n");
    const char *end = strstr(readme, "<!-- params:end -->");
    int same = 0;
    if (begin && end) {
        begin += strlen("<!-- params:begin -->\n");
        size_t len = end > begin ? (size_t)(end - begin) : 0;
        same = len == strlen(expected) && memcmp(begin, expected, len) == 0;
    }
    if (!same)
        printf("README.md's parameter table differs from pkss_param_at(); paste this "
               "between the params markers:\n%s", expected);
    else
        printf("  README parameter table: %zu rows, as pkss_param_at()\n", pkss_param_count());
    assert_true(same);
    free(readme);
}

int main(void)
{
    pkss_test_seed(PROGRAM, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_readme_parameter_table),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
